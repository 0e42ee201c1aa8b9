//! A byte-level mutator in the style of AFL/libFuzzer's havoc stage, deterministic from a seed.
//!
//! Each input is a seed with 1–6 stacked mutations (bit flips, "interesting" integers and
//! floats over length prefixes and fields, deletions, insertions, duplications, truncation,
//! dictionary tokens, splices with another seed), or now and then plain random bytes. Length
//! fields are where parsers go wrong, so 32-bit values near 0, 2³¹ and 2³² are over-weighted.
//! Seeds that are JSON (models, gesture files, parameter files converted to JSON, which YAML
//! reads too) also get structural mutations half of the time: a random value of the document
//! replaced by an extreme number, an array shortened, emptied or grown, a key removed, a value
//! of another type — inputs that parse and then test the checks behind the parser.

use rand::{Rng, RngCore};
use serde_json::Value;

/// 32-bit values that trip length and index arithmetic.
const INTERESTING_U32: [u32; 12] =
    [0, 1, 2, 3, 0x7f, 0x80, 0xff, 0xffff, 0x7fff_ffff, 0x8000_0000, 0xffff_fffe, 0xffff_ffff];

/// 64-bit floats that trip numeric checks.
const INTERESTING_F64: [f64; 9] =
    [f64::NAN, f64::INFINITY, f64::NEG_INFINITY, -0.0, 0.0, 1e308, -1e308, 5e-324, -1.0];

/// Makes inputs from seeds.
#[derive(Debug)]
pub struct Mutator<'a> {
    seeds: &'a [Vec<u8>],
    dictionary: &'a [&'a [u8]],
    max_len: usize,
    json_seeds: Vec<Value>,
}

impl<'a> Mutator<'a> {
    /// A mutator over `seeds` (at least one) with text `dictionary` tokens; inputs are cut to
    /// `max_len` bytes.
    pub fn new(seeds: &'a [Vec<u8>], dictionary: &'a [&'a [u8]], max_len: usize) -> Self {
        let json_seeds = seeds
            .iter()
            .filter_map(|s| serde_json::from_slice::<Value>(s).ok())
            .filter(|v| v.is_object() || v.is_array())
            .collect();
        Self { seeds, dictionary, max_len, json_seeds }
    }

    /// The next input, written into `out` (reused between calls).
    pub fn next(&self, rng: &mut impl RngCore, out: &mut Vec<u8>) {
        out.clear();
        if self.seeds.is_empty() || rng.random_ratio(1, 20) {
            let len = rng.random_range(0..=256.min(self.max_len));
            out.extend((0..len).map(|_| rng.random::<u8>()));
            return;
        }
        if !self.json_seeds.is_empty() && rng.random() {
            let mut doc = self.json_seeds[rng.random_range(0..self.json_seeds.len())].clone();
            for _ in 0..rng.random_range(1..=3) {
                mutate_json(rng, &mut doc, 0);
            }
            // serde_json writes any Value; an error here would only mean an empty input.
            out.extend(serde_json::to_vec(&doc).unwrap_or_default());
            out.truncate(self.max_len);
            return;
        }
        out.extend_from_slice(&self.seeds[rng.random_range(0..self.seeds.len())]);
        let stacked = 1 << rng.random_range(0..3); // 1, 2 or 4
        for _ in 0..stacked {
            self.mutate_once(rng, out);
        }
        out.truncate(self.max_len);
    }

    fn mutate_once(&self, rng: &mut impl RngCore, buf: &mut Vec<u8>) {
        let op = rng.random_range(0..10);
        if buf.is_empty() && op != 4 && op != 7 {
            buf.push(rng.random());
            return;
        }
        let len = buf.len();
        match op {
            0 => {
                let i = rng.random_range(0..len);
                buf[i] ^= 1 << rng.random_range(0..8);
            }
            1 => {
                let i = rng.random_range(0..len);
                buf[i] = [0u8, 1, 0x7f, 0x80, 0xff, b'-', b'9', b'.', b'e'][rng.random_range(0..9)];
            }
            2 => {
                // A length prefix or count: CDR aligns them to 4 bytes.
                let v = INTERESTING_U32[rng.random_range(0..INTERESTING_U32.len())];
                let v = if rng.random_ratio(1, 4) { v.wrapping_add(rng.random_range(0..16)) } else { v };
                let at = if rng.random() { rng.random_range(0..len) & !3 } else { rng.random_range(0..len) };
                let bytes = if rng.random() { v.to_le_bytes() } else { v.to_be_bytes() };
                for (k, b) in bytes.iter().enumerate() {
                    if let Some(slot) = buf.get_mut(at + k) {
                        *slot = *b;
                    }
                }
            }
            3 => {
                let from = rng.random_range(0..len);
                let n = rng.random_range(1..=64.min(len - from));
                buf.drain(from..from + n);
            }
            4 => {
                let at = rng.random_range(0..=len);
                let n = rng.random_range(1..=16);
                let bytes: Vec<u8> = (0..n).map(|_| rng.random()).collect();
                buf.splice(at..at, bytes);
            }
            5 => {
                let from = rng.random_range(0..len);
                let n = rng.random_range(1..=256.min(len - from));
                let copy = buf[from..from + n].to_vec();
                let at = rng.random_range(0..=len);
                buf.splice(at..at, copy);
            }
            6 => {
                let keep = rng.random_range(0..len);
                buf.truncate(keep);
            }
            7 => {
                if self.dictionary.is_empty() {
                    return;
                }
                let token = self.dictionary[rng.random_range(0..self.dictionary.len())];
                let at = rng.random_range(0..=len);
                if rng.random() {
                    buf.splice(at..at, token.iter().copied());
                } else {
                    let end = (at + token.len()).min(len);
                    buf.splice(at..end, token.iter().copied());
                }
            }
            8 => {
                let other = &self.seeds[rng.random_range(0..self.seeds.len())];
                if other.is_empty() {
                    return;
                }
                let cut = rng.random_range(0..len);
                let from = rng.random_range(0..other.len());
                buf.truncate(cut);
                buf.extend_from_slice(&other[from..]);
            }
            _ => {
                let v = INTERESTING_F64[rng.random_range(0..INTERESTING_F64.len())];
                let at = rng.random_range(0..len) & !7;
                for (k, b) in v.to_le_bytes().iter().enumerate() {
                    if let Some(slot) = buf.get_mut(at + k) {
                        *slot = *b;
                    }
                }
            }
        }
    }
}

/// Replaces, removes or resizes one value somewhere in `doc` (a random walk from the root).
fn mutate_json(rng: &mut impl RngCore, doc: &mut Value, depth: usize) {
    let descend = depth < 12 && rng.random_ratio(4, 5);
    match doc {
        Value::Object(map) if descend && !map.is_empty() => {
            let key = map.keys().nth(rng.random_range(0..map.len())).cloned().unwrap_or_default();
            if rng.random_ratio(1, 8) {
                map.remove(&key);
            } else if let Some(v) = map.get_mut(&key) {
                mutate_json(rng, v, depth + 1);
            }
        }
        Value::Array(items) if descend && !items.is_empty() => {
            let i = rng.random_range(0..items.len());
            match rng.random_range(0..8) {
                0 => {
                    items.remove(i);
                }
                1 => {
                    let copy = items[i].clone();
                    items.insert(i, copy);
                }
                2 => items.truncate(i),
                3 => items.clear(),
                _ => mutate_json(rng, &mut items[i], depth + 1),
            }
        }
        _ => *doc = extreme_value(rng, doc),
    }
}

/// A value that tests range checks: an extreme number, another type, an empty container.
fn extreme_value(rng: &mut impl RngCore, old: &Value) -> Value {
    let numbers = [0.0, -1.0, 1e308, -1e308, 1e-320, 0.5, 2.0, 1e9, -1e9, 4294967296.0];
    match rng.random_range(0..10) {
        0..=4 => serde_json::json!(numbers[rng.random_range(0..numbers.len())]),
        5 => serde_json::json!(u64::MAX),
        6 => Value::Null,
        7 => Value::String(if rng.random() { String::new() } else { "x".repeat(rng.random_range(1..300)) }),
        8 => Value::Array(vec![old.clone(); rng.random_range(0..4)]),
        _ => Value::Bool(rng.random()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;

    #[test]
    fn inputs_are_deterministic_bounded_and_varied() {
        let seeds = vec![b"schema(add(Obj), [])".to_vec(), vec![0u8; 40]];
        let dict: &[&[u8]] = &[b"NaN", b"("];
        let m = Mutator::new(&seeds, dict, 64);
        let run = |seed| {
            let mut rng = ChaCha8Rng::seed_from_u64(seed);
            let mut out = Vec::new();
            (0..200)
                .map(|_| {
                    m.next(&mut rng, &mut out);
                    out.clone()
                })
                .collect::<Vec<_>>()
        };
        let a = run(7);
        assert_eq!(a, run(7), "same seed, same inputs");
        assert!(a.iter().all(|i| i.len() <= 64));
        let distinct: std::collections::HashSet<_> = a.iter().collect();
        assert!(distinct.len() > 150, "only {} distinct inputs of 200", distinct.len());
        assert!(a.iter().any(|i| !seeds.contains(i)));
    }
}
