//! The hand-over between the DDS side and the fDED worker thread: a latest-frame slot.
//!
//! The DDS thread posts every message as it arrives; the worker takes everything at once when
//! a depth image is waiting. Only the newest image is kept: an image posted while the previous
//! one still waits replaces it and is counted as dropped, so a slow frame never builds a
//! queue. Camera info keeps the newest too; joint states are kept in arrival order (bounded,
//! oldest dropped first) so the worker can match them to the frame's stamp; `/tf_static`
//! messages are all kept (they are few).

use std::collections::VecDeque;
use std::sync::{Condvar, Mutex, MutexGuard};
use std::time::Duration;

use cowork_msgs::msg::ObjectStream;
use cowork_msgs::sensor_msgs::{CameraInfo, Image, JointState};
use cowork_msgs::tf2_msgs::TFMessage;

/// Joint states held between two frames at most (2 s of a 1 kHz publisher).
pub const MAX_PENDING_JOINT_STATES: usize = 2048;

/// `/manipulated_objects` lists held between two frames at most (oldest dropped first).
pub const MAX_PENDING_MANIPULATED: usize = 256;

/// Everything that arrived since the worker last took.
#[derive(Debug, Default)]
pub struct Batch {
    /// The newest depth image.
    pub image: Option<Image>,
    /// The newest camera info.
    pub camera_info: Option<CameraInfo>,
    /// Joint states, oldest first.
    pub joint_states: Vec<JointState>,
    /// `/tf_static` messages, oldest first.
    pub tf_static: Vec<TFMessage>,
    /// `/manipulated_objects` lists, oldest first.
    pub manipulated: Vec<ObjectStream>,
}

#[derive(Debug, Default)]
struct State {
    pending: Batch,
    joint_states: VecDeque<JointState>,
    manipulated: VecDeque<ObjectStream>,
    dropped_images: u64,
    closed: bool,
}

/// The latest-frame slot shared by the DDS thread and the worker.
#[derive(Debug, Default)]
pub struct Inbox {
    state: Mutex<State>,
    image_ready: Condvar,
}

impl Inbox {
    /// An empty, open inbox.
    pub fn new() -> Self {
        Self::default()
    }

    fn lock(&self) -> MutexGuard<'_, State> {
        // A panicking holder leaves plain data behind; keep going with it.
        self.state.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Posts a depth image, replacing (and counting as dropped) one still waiting.
    pub fn post_image(&self, image: Image) {
        let mut s = self.lock();
        if s.pending.image.replace(image).is_some() {
            s.dropped_images += 1;
        }
        drop(s);
        self.image_ready.notify_one();
    }

    /// Posts a camera info, replacing one still waiting.
    pub fn post_camera_info(&self, info: CameraInfo) {
        self.lock().pending.camera_info = Some(info);
    }

    /// Posts a joint state; beyond [`MAX_PENDING_JOINT_STATES`] waiting, the oldest goes.
    pub fn post_joint_state(&self, state: JointState) {
        let mut s = self.lock();
        if s.joint_states.len() >= MAX_PENDING_JOINT_STATES {
            s.joint_states.pop_front();
        }
        s.joint_states.push_back(state);
    }

    /// Posts a `/manipulated_objects` list; beyond [`MAX_PENDING_MANIPULATED`] waiting, the
    /// oldest goes.
    pub fn post_manipulated(&self, msg: ObjectStream) {
        let mut s = self.lock();
        if s.manipulated.len() >= MAX_PENDING_MANIPULATED {
            s.manipulated.pop_front();
        }
        s.manipulated.push_back(msg);
    }

    /// Posts a `/tf_static` message.
    pub fn post_tf_static(&self, msg: TFMessage) {
        self.lock().pending.tf_static.push(msg);
    }

    /// Waits up to `timeout` for an image, then takes everything waiting (image or not).
    /// `None` once the inbox is closed.
    pub fn take(&self, timeout: Duration) -> Option<Batch> {
        let s = self.lock();
        let (mut s, _) = self
            .image_ready
            .wait_timeout_while(s, timeout, |s| s.pending.image.is_none() && !s.closed)
            .unwrap_or_else(|e| e.into_inner());
        if s.closed {
            return None;
        }
        let mut batch = std::mem::take(&mut s.pending);
        batch.joint_states.extend(s.joint_states.drain(..));
        batch.manipulated.extend(s.manipulated.drain(..));
        Some(batch)
    }

    /// Images replaced before the worker took them.
    pub fn dropped_images(&self) -> u64 {
        self.lock().dropped_images
    }

    /// Wakes the worker and makes every later [`take`](Self::take) return `None`.
    pub fn close(&self) {
        self.lock().closed = true;
        self.image_ready.notify_all();
    }
}

#[cfg(test)]
mod tests {
    use std::sync::Arc;
    use std::time::Instant;

    use cowork_msgs::builtin_interfaces::Time;

    use super::*;

    fn image(sec: i32) -> Image {
        let mut m = Image::default();
        m.header.stamp = Time { sec, nanosec: 0 };
        m
    }

    #[test]
    fn only_the_newest_image_waits_and_the_others_are_counted() {
        let inbox = Inbox::new();
        for s in 1..=3 {
            inbox.post_image(image(s));
        }
        inbox.post_joint_state(JointState::default());
        inbox.post_joint_state(JointState::default());
        let b = inbox.take(Duration::ZERO).expect("open");
        assert_eq!(b.image.expect("an image").header.stamp.sec, 3);
        assert_eq!(b.joint_states.len(), 2);
        assert_eq!(inbox.dropped_images(), 2);
        let empty = inbox.take(Duration::from_millis(1)).expect("open");
        assert!(empty.image.is_none() && empty.joint_states.is_empty());
    }

    #[test]
    fn joint_states_are_bounded_oldest_first_out() {
        let inbox = Inbox::new();
        for i in 0..MAX_PENDING_JOINT_STATES + 10 {
            let mut js = JointState::default();
            js.header.stamp = Time::from_nanos(i as i64);
            inbox.post_joint_state(js);
        }
        let b = inbox.take(Duration::ZERO).expect("open");
        assert_eq!(b.joint_states.len(), MAX_PENDING_JOINT_STATES);
        assert_eq!(b.joint_states[0].header.stamp.to_nanos(), 10);
    }

    #[test]
    fn a_waiting_worker_wakes_on_an_image_and_on_close() {
        let inbox = Arc::new(Inbox::new());
        let poster = {
            let inbox = Arc::clone(&inbox);
            std::thread::spawn(move || {
                std::thread::sleep(Duration::from_millis(20));
                inbox.post_image(image(7));
                std::thread::sleep(Duration::from_millis(20));
                inbox.close();
            })
        };
        let t0 = Instant::now();
        let b = inbox.take(Duration::from_secs(30)).expect("open");
        assert_eq!(b.image.expect("woken by the image").header.stamp.sec, 7);
        assert!(inbox.take(Duration::from_secs(30)).is_none(), "closed");
        assert!(t0.elapsed() < Duration::from_secs(20), "woken, not timed out");
        poster.join().expect("poster");
    }
}
