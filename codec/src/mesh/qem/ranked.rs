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

/// The key of a non-negative `error`: non-negative floats order like their bits, and the 14
/// mantissa bits [`KEY_MASK`] keeps (errors within 6·10⁻⁵ of each other tie and keep their
/// order) let the sort take two radix passes.
pub(super) fn key_of(error: f32) -> u32 {
    error.to_bits() & KEY_MASK
}

impl Entry {
    pub fn error(&self) -> f32 {
        f32::from_bits(self.key)
    }
}

/// Bits of a key that count: the f32 error's sign (always 0), exponent and top 14 mantissa
/// bits. Ordering errors needs no more, and 22 bits sort in two radix passes instead of three.
const KEY_MASK: u32 = !((1 << LOW_BITS) - 1);
/// Low mantissa bits dropped from the keys.
const LOW_BITS: u32 = 9;

/// Sorts by key: LSD radix, 11 bits a pass over the 22 bits [`KEY_MASK`] keeps, skipping
/// passes where every key has the same digit. Stable.
pub(super) fn radix_sort(items: &mut Vec<Entry>, scratch: &mut Vec<Entry>) {
    const BITS: u32 = 11;
    const BUCKETS: usize = 1 << BITS;
    // Late passes re-rank a few dozen pairs: three sweeps over 2,048 counters would cost more
    // than the sort (the standard sort is stable too, so the order is the same).
    // Either path sorts any length alike (every key is masked by `KEY_MASK`), so `<` as `<=`,
    // `==` or `>` is equivalent.
    if items.len() < 256 {
        items.sort_by_key(|e| e.key);
        return;
    }
    // Both digits' counts in one sweep (a digit's counts do not depend on the order).
    let mut counts = [[0usize; BUCKETS]; 2];
    for e in items.iter() {
        counts[0][(e.key >> LOW_BITS) as usize & (BUCKETS - 1)] += 1;
        counts[1][(e.key >> (LOW_BITS + BITS)) as usize & (BUCKETS - 1)] += 1;
    }
    for (counts, shift) in counts.iter_mut().zip([LOW_BITS, LOW_BITS + BITS]) {
        if counts.contains(&items.len()) {
            continue;
        }
        // Each digit's first slot.
        let mut at = 0;
        for c in counts.iter_mut() {
            (*c, at) = (at, at + *c);
        }
        scratch.clear();
        scratch.resize(items.len(), Entry::default());
        for e in items.iter() {
            let d = (e.key >> shift) as usize & (BUCKETS - 1);
            scratch[counts[d]] = *e;
            counts[d] += 1;
        }
        std::mem::swap(items, scratch);
    }
}

/// Merges the sorted `old`, less those of its first `checked` entries that `valid` refuses, with
/// the sorted `fresh` into `out` (older entries first among equal keys). Returns how many
/// entries of `old` were left out; `old`'s first `checked` entries are scratch afterwards.
///
/// The checked part is compacted in place without a branch per entry (whether a pair is still
/// valid is a coin toss to the branch predictor), then both parts are copied in runs between
/// the fresh entries, each run's end found by galloping: a pass re-ranks a few thousand pairs
/// into a list several times longer, and moving it entry by entry, compare by compare, took
/// 8 % of a fandisk run.
pub(super) fn merge(
    old: &mut [Entry],
    fresh: &[Entry],
    out: &mut Vec<Entry>,
    checked: usize,
    valid: impl Fn(&Entry) -> bool,
) -> usize {
    let checked = checked.min(old.len());
    let mut kept = 0;
    for i in 0..checked {
        let e = old[i];
        old[kept] = e;
        kept += usize::from(valid(&e));
    }
    out.clear();
    // Only the capacity: `- checked` as `+ checked` reserves more, and is equivalent.
    out.reserve(kept + old.len() - checked + fresh.len());
    let mut j = 0;
    for part in [&old[..kept], &old[checked..]] {
        let mut rest = part;
        while let Some(f) = fresh.get(j) {
            let run = leading_at_most(rest, f.key);
            out.extend_from_slice(&rest[..run]);
            rest = &rest[run..];
            if rest.is_empty() {
                // The fresh entry may still belong after entries of the next part.
                break;
            }
            out.push(*f);
            j += 1;
        }
        out.extend_from_slice(rest);
    }
    out.extend_from_slice(&fresh[j..]);
    old.len() + fresh.len() - out.len()
}

/// How many entries at the start of the sorted `items` have a key ≤ `key`: galloping from the
/// front (the runs between fresh entries are short), then a binary search.
fn leading_at_most(items: &[Entry], key: u32) -> usize {
    let (mut lo, mut step) = (0, 1);
    // Any growth of `lo` and `step` that keeps `items[..lo]` at most `key` finds the same
    // answer: `lo += step` as `*=` (lo stays 0) and `step *= 2` as `+= 2` are equivalent.
    while lo + step <= items.len() && items[lo + step - 1].key <= key {
        lo += step;
        step *= 2;
    }
    // `+` as `*` is equivalent: the answer is at most min(lo + step − 1, len), and lo · step
    // (lo = step − 1) is 0 only when the answer is 0, 2 when step is 2, else ≥ lo + step.
    let hi = (lo + step).min(items.len());
    lo + items[lo..hi].partition_point(|e| e.key <= key)
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
        let mut items = entries(&floats.map(key_of));
        radix_sort(&mut items, &mut Vec::new());
        let got: Vec<f32> = items.iter().map(Entry::error).collect();
        let want = [0.0f32, 1e-30, 1e-30, 2.0, 3.5, 3.5, 7.0, f32::INFINITY]
            .map(|f| f32::from_bits(key_of(f)));
        assert_eq!(got, want.to_vec());
        // Equal keys keep their input order.
        assert!(items[1].a < items[2].a && items[4].a < items[5].a);
    }

    #[test]
    fn long_lists_sort_by_radix_like_a_stable_sort() {
        // Enough entries for the radix path, with repeated keys across many exponents.
        let keys: Vec<u32> = (0..5000u32)
            .map(|i| {
                let f = (i.wrapping_mul(2_654_435_761) % 977) as f32 * 1e-3;
                key_of(f * f * f)
            })
            .collect();
        let mut items = entries(&keys);
        let mut want = items.clone();
        want.sort_by_key(|e| e.key);
        radix_sort(&mut items, &mut Vec::new());
        assert_eq!(items, want);
    }

    #[test]
    fn merge_interleaves_and_filters() {
        let mut old = entries(&[1, 3, 5, 7]);
        let fresh = entries(&[2, 3, 8]);
        let mut out = Vec::new();
        assert_eq!(merge(&mut old, &fresh, &mut out, 3, |e| e.key != 5), 1);
        let keys: Vec<u32> = out.iter().map(|e| e.key).collect();
        assert_eq!(keys, vec![1, 2, 3, 3, 7, 8]);
    }

    #[test]
    fn merge_takes_more_fresh_entries_than_it_had_old_ones() {
        // Fresh entries marked b = 1, so that an old one in their place shows.
        let fresh: Vec<Entry> = entries(&[1, 2, 3, 4, 6, 7])
            .into_iter()
            .map(|e| Entry { b: 1, ..e })
            .collect();
        let mut out = Vec::new();
        // One old entry among six fresh ones.
        let dropped = merge(&mut entries(&[5]), &fresh, &mut out, 0, |_| true);
        let keys: Vec<u32> = out.iter().map(|e| e.key).collect();
        assert_eq!((dropped, keys), (0, vec![1, 2, 3, 4, 5, 6, 7]));
        // Both old entries looked at and refused.
        let dropped = merge(&mut entries(&[1, 9]), &fresh, &mut out, 2, |_| false);
        assert_eq!((dropped, out), (2, fresh));
    }

    #[test]
    fn merge_matches_a_stable_sort_of_both_lists() {
        // Long runs of equal keys: old entries must stay ahead of fresh ones with their key.
        let old = entries(&(0..300u32).map(|i| i / 7 * 2).collect::<Vec<_>>());
        let fresh: Vec<Entry> = entries(&(0..90u32).map(|i| i / 3 * 5).collect::<Vec<_>>())
            .into_iter()
            .map(|e| Entry { b: 1, ..e })
            .collect();
        for checked in [0, 40, 300] {
            let mut out = Vec::new();
            let mut want = [old.clone(), fresh.clone()].concat();
            want.retain(|e| e.a % 5 != 0 || e.b == 1 || e.a as usize >= checked);
            want.sort_by_key(|e| e.key);
            let dropped = merge(&mut old.clone(), &fresh, &mut out, checked, |e| {
                e.a % 5 != 0
            });
            assert_eq!(dropped, old.len() + fresh.len() - want.len());
            assert_eq!(out, want);
        }
    }
}
