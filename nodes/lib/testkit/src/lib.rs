//! Test-only helpers shared by the cowork crates (used as a dev-dependency only).
//!
//! [`CountingAllocator`] forwards to the system allocator and counts allocations per thread, so a
//! zero-allocation test is not disturbed by other test threads:
//!
//! ```ignore
//! #[global_allocator]
//! static GLOBAL: cowork_testkit::CountingAllocator = cowork_testkit::CountingAllocator;
//!
//! let before = cowork_testkit::allocations();
//! hot_loop();
//! assert_eq!(cowork_testkit::allocations() - before, 0);
//! ```
#![allow(unsafe_code)] // a GlobalAlloc implementation is unsafe by definition

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;

thread_local! {
    static ALLOCATIONS: Cell<usize> = const { Cell::new(0) };
}

/// System allocator that counts `alloc` and `realloc` calls of the current thread.
#[derive(Debug, Clone, Copy, Default)]
pub struct CountingAllocator;

// SAFETY: every call is forwarded unchanged to the system allocator; counting touches only a
// const-initialised thread-local `Cell` (no allocation, `try_with` tolerates thread teardown).
unsafe impl GlobalAlloc for CountingAllocator {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        let _ = ALLOCATIONS.try_with(|c| c.set(c.get() + 1));
        // SAFETY: same contract as the caller's.
        unsafe { System.alloc(layout) }
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: same contract as the caller's.
        unsafe { System.dealloc(ptr, layout) }
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        let _ = ALLOCATIONS.try_with(|c| c.set(c.get() + 1));
        // SAFETY: same contract as the caller's.
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

/// Allocations (and reallocations) made so far on the calling thread, when
/// [`CountingAllocator`] is the global allocator; always 0 otherwise.
pub fn allocations() -> usize {
    ALLOCATIONS.with(Cell::get)
}
