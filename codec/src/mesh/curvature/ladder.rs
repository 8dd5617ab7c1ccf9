//! The fixed ladder of ε bounds that `to_error` (from 0.15 up) and `to_faces` climb.
//!
//! One decimation run to a bound E is greedy: which removals go first decides which can go
//! later, so a run to a larger E could stop with more faces than a run to a smaller one (the
//! vase: 1 face at ε = 2, 207 at 3, 1 at 4). Climbing one fixed ladder of bounds, each rung
//! continuing from the one below as the paper's levels do, makes every answer a prefix of
//! the same run: a larger E, or a smaller face target, never keeps more faces. A bound
//! between two rungs is taken down to the rung below it, so ε stays within what was asked.
//!
//! The ladder starts at the paper's first level and rises by its level spacing, 0.05, so its
//! first three rungs are the three levels and `to_error(0.25)` is `levels`' third level. A
//! bound below 0.15 is one run straight to it, as the first rung is: few removals, and a
//! rung below would change (and slow) every answer above it.

use super::decimate::Decimator;

/// Rungs every 1/20 from 0.15 to 1.
const LINEAR: u32 = 18;

/// The `k`th bound of the ladder, strictly increasing in `k`: (k + 3) / 20 up to 1, then
/// 1.25^(k − 17).
pub(crate) fn rung(k: u32) -> f64 {
    if k < LINEAR {
        f64::from(k + 3) / 20.0
    } else {
        1.25_f64.powi((k + 1 - LINEAR) as i32)
    }
}

/// The highest rung at or below `bound`, if any (none below the first, 0.15).
pub(crate) fn top_rung(bound: f64) -> Option<u32> {
    let mut k = None;
    let mut next = 0;
    while next < u32::MAX && rung(next) <= bound {
        k = Some(next);
        next += 1;
    }
    k
}

/// The lowest finite rung at or above `bound` (`None` past every one).
fn rung_at_least(bound: f64) -> Option<u32> {
    let mut k = 0;
    loop {
        let r = rung(k);
        if !r.is_finite() {
            return None;
        }
        if r >= bound {
            return Some(k);
        }
        k += 1;
    }
}

/// Climbs the ladder up to rung `top`, stopping as soon as at most `floor` faces remain
/// (mid-rung). A rung that removes nothing is followed by the first rung that lets the
/// least-ε refused removal pass, which is what the rungs between would do: none of them
/// changes anything.
pub(crate) fn climb(d: &mut Decimator, top: u32, floor: usize) {
    let mut k = 0;
    while k <= top && d.faces() > floor {
        let before = d.vertices();
        let least = d.run_to_error_until(rung(k), floor);
        if d.vertices() != before {
            k += 1;
            continue;
        }
        // Nothing went: only a removal refused for its ε can go at a higher bound.
        match least.and_then(rung_at_least) {
            Some(next) => k = next.max(k + 1),
            None => return,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_ladder_rises_from_the_papers_levels() {
        let rungs: Vec<f64> = (0..200).map(rung).collect();
        assert!(rungs.windows(2).all(|w| w[0] < w[1]), "{rungs:?}");
        assert_eq!(rungs[..3], super::super::PAPER_LEVELS);
        for level in super::super::PAPER_LEVELS.into_iter().chain([0.5, 1.0]) {
            assert_eq!(rung(top_rung(level).unwrap()), level);
        }
        assert_eq!(rung(LINEAR - 1), 1.0);
        assert_eq!(rung(LINEAR), 1.25);
        assert_eq!(top_rung(0.149), None);
        assert_eq!(rung(top_rung(0.17).unwrap()), 0.15);
        assert_eq!(rung(top_rung(0.199_999).unwrap()), 0.15);
        assert!(rung(top_rung(1e300).unwrap()) <= 1e300);
        assert_eq!(rung_at_least(0.16), top_rung(0.2));
        assert_eq!(rung_at_least(0.2), top_rung(0.2));
        assert_eq!(rung_at_least(0.01), Some(0));
        assert_eq!(rung_at_least(f64::INFINITY), None);
    }
}
