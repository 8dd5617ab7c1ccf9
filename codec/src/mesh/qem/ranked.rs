//! The ranked candidate list: contraction pairs sorted by error, with lazy invalidation.
//!
//! A pass walks the list in order; pairs whose vertices changed since they were ranked are
//! recognised by their version stamps and skipped, and the pairs of moved vertices are ranked
//! afresh, sorted and merged back in. Sorting is an LSD radix sort on the error's bits and
//! merging is linear, so the list costs a few sequential sweeps per pass instead of the
//! cache-missing sift of a heap per candidate.

/// A candidate pair. `key` is the bit pattern of a non-negative `f32` error, so integer order
/// is float order; `stamp` is the sum of both vertices' version counters when it was ranked
/// (the counters only grow, so an unchanged sum means neither vertex changed).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(super) struct Entry {
    pub key: u32,
    pub a: u32,
    pub b: u32,
    pub stamp: u32,
}

impl Entry {
    pub fn error(&self) -> f32 {
        f32::from_bits(self.key)
    }
}

/// Sorts by key: LSD radix, 11 bits a pass (keys are non-negative f32 bits: 31 significant
/// bits, three passes), skipping passes where every key has the same digit. Stable.
pub(super) fn radix_sort(items: &mut Vec<Entry>, scratch: &mut Vec<Entry>) {
    const BITS: u32 = 11;
    const BUCKETS: usize = 1 << BITS;
    let mut counts = vec![0usize; BUCKETS + 1];
    scratch.clear();
    scratch.resize(items.len(), Entry::default());
    for shift in [0, BITS, 2 * BITS] {
        counts.fill(0);
        for e in items.iter() {
            counts[((e.key >> shift) as usize & (BUCKETS - 1)) + 1] += 1;
        }
        if counts.contains(&items.len()) {
            continue;
        }
        for i in 0..BUCKETS {
            counts[i + 1] += counts[i];
        }
        for e in items.iter() {
            let d = (e.key >> shift) as usize & (BUCKETS - 1);
            scratch[counts[d]] = *e;
            counts[d] += 1;
        }
        std::mem::swap(items, scratch);
    }
}

/// Merges the entries of the sorted `old` that `keep` accepts with the sorted `fresh` into
/// `out` (older entries first among equal keys).
pub(super) fn merge(
    old: &[Entry],
    fresh: &[Entry],
    out: &mut Vec<Entry>,
    keep: impl Fn(&Entry) -> bool,
) {
    out.clear();
    out.reserve(old.len() + fresh.len());
    let mut j = 0;
    for e in old.iter().filter(|e| keep(e)) {
        while j < fresh.len() && fresh[j].key < e.key {
            out.push(fresh[j]);
            j += 1;
        }
        out.push(*e);
    }
    out.extend_from_slice(&fresh[j..]);
}

#[cfg(test)]
mod tests {
    use super::*;

    fn entries(keys: &[u32]) -> Vec<Entry> {
        keys.iter()
            .enumerate()
            .map(|(i, &key)| Entry {
                key,
                a: i as u32,
                ..Entry::default()
            })
            .collect()
    }

    #[test]
    fn radix_sort_orders_float_bits_stably() {
        let floats = [3.5f32, 0.0, 1e-30, 7.0, 3.5, f32::INFINITY, 2.0, 1e-30];
        let mut items = entries(&floats.map(f32::to_bits));
        radix_sort(&mut items, &mut Vec::new());
        let got: Vec<f32> = items.iter().map(Entry::error).collect();
        assert_eq!(
            got,
            vec![0.0, 1e-30, 1e-30, 2.0, 3.5, 3.5, 7.0, f32::INFINITY]
        );
        // Equal keys keep their input order.
        assert!(items[1].a < items[2].a && items[4].a < items[5].a);
    }

    #[test]
    fn merge_interleaves_and_filters() {
        let old = entries(&[1, 3, 5, 7]);
        let fresh = entries(&[2, 3, 8]);
        let mut out = Vec::new();
        merge(&old, &fresh, &mut out, |e| e.key != 5);
        let keys: Vec<u32> = out.iter().map(|e| e.key).collect();
        assert_eq!(keys, vec![1, 2, 3, 3, 7, 8]);
    }
}
