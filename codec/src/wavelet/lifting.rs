//! Lifting steps with whole-sample symmetric extension, and the separable 2-D driver that runs
//! a 1-D lifting scheme level by level so the output is exactly the [`Layout`] of `subbands`.
//!
//! References: I. Daubechies and W. Sweldens, "Factoring wavelet transforms into lifting
//! steps", J. Fourier Anal. Appl. 4(3), 1998; ISO/IEC 15444-1 (JPEG 2000 Part 1), Annex F
//! (1-D lifting with symmetric extension, the 2-D interleaving of rows and columns).
//!
//! Every scheme here works on a signal already split into its even samples `s` (the low-pass,
//! `ceil(n/2)` of them) and odd samples `d` (the high-pass, `floor(n/2)`). A "sample" is a run
//! of `w` values: `w = 1` for one row, `w = row width` for the column pass. Lifting a block of
//! rows row-vector-wise turns the column pass into sequential, vectorisable loops instead of a
//! strided gather per column.
//!
//! Whole-sample symmetric extension (`x[-1] = x[1]`, `x[n] = x[n-2]`) in split form reads
//! `d[-1] = d[0]`; `s[ns] = s[ns-1]` when n is even; `d[nd] = d[nd-1]` when n is odd. It is
//! what makes constants, ramps (for 5/3) and the alternating signal survive the boundary, and
//! it needs no sample beyond the signal, so any length n ≥ 2 works; n = 1 is the identity.

use super::Layout;
use crate::Grid;

/// A 1-D lifting scheme on split samples (see the module doc for `s`, `d` and `w`).
///
/// Contract: `s.len() == ns * w`, `d.len() == nd * w` with `nd ≥ 1` and `ns ∈ {nd, nd + 1}`.
pub(crate) trait Scheme<T> {
    fn analyze(&self, s: &mut [T], d: &mut [T], w: usize);
    fn synthesize(&self, s: &mut [T], d: &mut [T], w: usize);
}

/// Predict step: `d[i] = op(d[i], s[i], s[i+1])`, with `s[ns] = s[ns-1]` when n is even.
#[inline]
pub(crate) fn predict<T: Copy>(s: &[T], d: &mut [T], w: usize, op: impl Fn(T, T, T) -> T) {
    let (ns, nd) = (s.len() / w, d.len() / w);
    debug_assert!(nd >= 1 && (ns == nd || ns == nd + 1));
    // Details with both even neighbours inside the signal: one flat zip, s shifted by w.
    let inner = nd.min(ns - 1);
    for ((x, &a), &b) in d[..inner * w]
        .iter_mut()
        .zip(&s[..inner * w])
        .zip(&s[w..(inner + 1) * w])
    {
        *x = op(*x, a, b);
    }
    // Even length: the last detail's right neighbour mirrors back onto its left one. (`<=`
    // would be equivalent: at `inner == nd` the loop's `d[inner * w..]` is empty.)
    if inner < nd {
        let last = &s[(ns - 1) * w..ns * w];
        for (x, &a) in d[inner * w..].iter_mut().zip(last) {
            *x = op(*x, a, a);
        }
    }
}

/// Update step: `s[i] = op(s[i], d[i-1], d[i])`, with `d[-1] = d[0]` and, when n is odd,
/// `d[nd] = d[nd-1]`.
#[inline]
pub(crate) fn update<T: Copy>(s: &mut [T], d: &[T], w: usize, op: impl Fn(T, T, T) -> T) {
    let (ns, nd) = (s.len() / w, d.len() / w);
    debug_assert!(nd >= 1 && (ns == nd || ns == nd + 1));
    // Left boundary: d[-1] mirrors onto d[0].
    for (x, &a) in s[..w].iter_mut().zip(&d[..w]) {
        *x = op(*x, a, a);
    }
    // Interior: s[i] for 1 ≤ i < nd sees d[i-1] and d[i]. The zip stops at the shortest of
    // the three, so a longer `d[..]` (`nd / 1` for `nd - 1`) would be equivalent.
    for ((x, &a), &b) in s[w..nd * w]
        .iter_mut()
        .zip(&d[..(nd - 1) * w])
        .zip(&d[w..nd * w])
    {
        *x = op(*x, a, b);
    }
    // Odd length: the last even sample's right neighbour mirrors back onto d[nd-1]. (`>=`
    // would be equivalent: at `ns == nd` the loop's `s[nd * w..]` is empty.)
    if ns > nd {
        for (x, &a) in s[nd * w..].iter_mut().zip(&d[(nd - 1) * w..]) {
            *x = op(*x, a, a);
        }
    }
}

/// Multiplies every value by `k` (the 9/7 normalisation).
#[inline]
pub(crate) fn scale(x: &mut [f64], k: f64) {
    for v in x {
        *v *= k;
    }
}

/// Forward transform of `grid` in place over `layout.levels()` levels: per level, the rows of
/// the current low-pass rectangle, then its columns.
///
/// `layout` must describe `grid`'s shape; a mismatch is a broken internal contract (a debug
/// assertion; release builds leave the grid untouched rather than index out of range).
pub(crate) fn forward_2d<T: Copy + Default, S: Scheme<T>>(
    grid: &mut Grid<T>,
    layout: &Layout,
    scheme: &S,
) {
    if !shape_matches(grid, layout) || grid.is_empty() {
        return;
    }
    let cols = grid.cols();
    // One scratch buffer for the whole transform: the level-1 column pass needs it all.
    let mut scratch = vec![T::default(); grid.len()];
    let data = grid.data_mut();
    for level in 1..=layout.levels() {
        let (h, w) = (layout.low_rows(level - 1), layout.low_cols(level - 1));
        // Rows: each row of the low rectangle becomes [low | high].
        if w >= 2 {
            for row in data.chunks_exact_mut(cols).take(h) {
                analyze_row(&mut row[..w], &mut scratch[..w], scheme);
            }
        }
        // Columns, a whole row-vector at a time so memory is read sequentially.
        if h >= 2 {
            analyze_cols(data, cols, h, w, &mut scratch[..h * w], scheme);
        }
    }
}

/// Inverse of [`forward_2d`]: per level from the coarsest, columns then rows.
pub(crate) fn inverse_2d<T: Copy + Default, S: Scheme<T>>(
    grid: &mut Grid<T>,
    layout: &Layout,
    scheme: &S,
) {
    if !shape_matches(grid, layout) || grid.is_empty() {
        return;
    }
    let cols = grid.cols();
    let mut scratch = vec![T::default(); grid.len()];
    let data = grid.data_mut();
    for level in (1..=layout.levels()).rev() {
        let (h, w) = (layout.low_rows(level - 1), layout.low_cols(level - 1));
        // Undo in the opposite order: columns first, then rows.
        if h >= 2 {
            synthesize_cols(data, cols, h, w, &mut scratch[..h * w], scheme);
        }
        if w >= 2 {
            for row in data.chunks_exact_mut(cols).take(h) {
                synthesize_row(&mut row[..w], &mut scratch[..w], scheme);
            }
        }
    }
}

/// Multi-level inverse of a single line (`w = 1`), for impulse responses: `lengths` lists the
/// signal length of each level to undo, coarsest first; `scratch` is as long as `line`.
pub(crate) fn inverse_line<S: Scheme<f64>>(
    line: &mut [f64],
    scratch: &mut [f64],
    lengths: impl Iterator<Item = usize>,
    scheme: &S,
) {
    for n in lengths {
        if n >= 2 && n <= line.len() && n <= scratch.len() {
            synthesize_row(&mut line[..n], &mut scratch[..n], scheme);
        }
    }
}

fn shape_matches<T>(grid: &Grid<T>, layout: &Layout) -> bool {
    let ok = grid.rows() == layout.rows() && grid.cols() == layout.cols();
    debug_assert!(
        ok,
        "layout {}×{} for a {}×{} grid",
        layout.rows(),
        layout.cols(),
        grid.rows(),
        grid.cols()
    );
    ok
}

/// Splits `row` (len ≥ 2) into even/odd halves in `scratch`, lifts, writes `[s | d]` back.
pub(crate) fn analyze_row<T: Copy, S: Scheme<T>>(row: &mut [T], scratch: &mut [T], scheme: &S) {
    let n = row.len();
    let (s, d) = scratch.split_at_mut(n.div_ceil(2));
    for ((a, b), pair) in s.iter_mut().zip(d.iter_mut()).zip(row.chunks_exact(2)) {
        *a = pair[0];
        *b = pair[1];
    }
    if n % 2 == 1 {
        s[n / 2] = row[n - 1];
    }
    scheme.analyze(s, d, 1);
    row.copy_from_slice(scratch);
}

fn synthesize_row<T: Copy, S: Scheme<T>>(row: &mut [T], scratch: &mut [T], scheme: &S) {
    let n = row.len();
    scratch.copy_from_slice(row);
    let (s, d) = scratch.split_at_mut(n.div_ceil(2));
    scheme.synthesize(s, d, 1);
    for ((a, b), pair) in s.iter().zip(d.iter()).zip(row.chunks_exact_mut(2)) {
        pair[0] = *a;
        pair[1] = *b;
    }
    if n % 2 == 1 {
        row[n - 1] = s[n / 2];
    }
}

/// Row index of scratch block `k` ↔ grid row: even rows go to the low block, odd rows after it.
#[inline]
fn split_block(r: usize, ns: usize) -> usize {
    if r.is_multiple_of(2) {
        r / 2
    } else {
        ns + r / 2
    }
}

/// Column pass over the `h × w` top-left rectangle (row stride `cols`): gathers whole rows into
/// `scratch` as `[even rows | odd rows]`, lifts them as row vectors, copies them back.
fn analyze_cols<T: Copy, S: Scheme<T>>(
    data: &mut [T],
    cols: usize,
    h: usize,
    w: usize,
    scratch: &mut [T],
    scheme: &S,
) {
    let ns = h.div_ceil(2);
    for (r, row) in data.chunks_exact(cols).take(h).enumerate() {
        let k = split_block(r, ns);
        scratch[k * w..(k + 1) * w].copy_from_slice(&row[..w]);
    }
    let (s, d) = scratch.split_at_mut(ns * w);
    scheme.analyze(s, d, w);
    for (row, block) in data.chunks_exact_mut(cols).zip(scratch.chunks_exact(w)) {
        row[..w].copy_from_slice(block);
    }
}

fn synthesize_cols<T: Copy, S: Scheme<T>>(
    data: &mut [T],
    cols: usize,
    h: usize,
    w: usize,
    scratch: &mut [T],
    scheme: &S,
) {
    let ns = h.div_ceil(2);
    for (row, block) in data.chunks_exact(cols).zip(scratch.chunks_exact_mut(w)) {
        block.copy_from_slice(&row[..w]);
    }
    let (s, d) = scratch.split_at_mut(ns * w);
    scheme.synthesize(s, d, w);
    for (r, row) in data.chunks_exact_mut(cols).take(h).enumerate() {
        let k = split_block(r, ns);
        row[..w].copy_from_slice(&scratch[k * w..(k + 1) * w]);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Sample `i` of `x` extended symmetrically (whole-sample) past both ends.
    fn at(x: &[i64], i: isize) -> i64 {
        let n = x.len() as isize;
        let m = if i < 0 {
            -i
        } else if i >= n {
            2 * (n - 1) - i
        } else {
            i
        };
        x[m as usize]
    }

    /// Interleaved reference: every odd sample less its two even neighbours, extending
    /// symmetrically, the way JPEG 2000 Annex F writes it.
    fn predict_reference(x: &mut [i64]) {
        let n = x.len() as isize;
        for i in (1..n).step_by(2) {
            x[i as usize] -= at(x, i - 1) + at(x, i + 1);
        }
    }

    /// The same for every even sample, plus its two odd neighbours.
    fn update_reference(x: &mut [i64]) {
        let n = x.len() as isize;
        for i in (0..n).step_by(2) {
            x[i as usize] += at(x, i - 1) + at(x, i + 1);
        }
    }

    #[test]
    fn split_steps_match_interleaved_symmetric_extension() {
        for n in 2..40usize {
            for w in [1, 3] {
                // w interleaved copies of the same signal, one per column of the row block.
                let x: Vec<i64> = (0..n as i64).map(|i| (i * 37 + 11) % 23 - 7).collect();
                let mut reference = x.clone();
                predict_reference(&mut reference);
                update_reference(&mut reference);

                let ns = n.div_ceil(2);
                let mut s: Vec<i64> = (0..ns)
                    .flat_map(|i| std::iter::repeat_n(x[2 * i], w))
                    .collect();
                let mut d: Vec<i64> = (0..n / 2)
                    .flat_map(|i| std::iter::repeat_n(x[2 * i + 1], w))
                    .collect();
                predict(&s, &mut d, w, |x, a, b| x - (a + b));
                update(&mut s, &d, w, |x, a, b| x + (a + b));
                for i in 0..n {
                    let got = if i % 2 == 0 {
                        &s[(i / 2) * w..(i / 2 + 1) * w]
                    } else {
                        &d[(i / 2) * w..(i / 2 + 1) * w]
                    };
                    assert!(
                        got.iter().all(|&g| g == reference[i]),
                        "n={n} w={w} sample {i}: {got:?} vs {}",
                        reference[i]
                    );
                }
            }
        }
    }

    /// Both axes are checked: a layout that differs in one must neither pass (a wrong level
    /// geometry) nor index past the grid.
    #[test]
    fn a_layout_of_another_shape_is_refused() {
        use super::super::legall53::Integer;
        for (rows, cols) in [(4, 5), (5, 4)] {
            let layout = Layout::full(rows, cols);
            let original = Grid::new(4, 4, (0..16).collect::<Vec<i32>>()).unwrap();
            let mut g = original.clone();
            let forward = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
                forward_2d(&mut g, &layout, &Integer);
            }));
            let mut h = original.clone();
            let inverse = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
                inverse_2d(&mut h, &layout, &Integer);
            }));
            let want = format!("layout {rows}×{cols} for a 4×4 grid");
            for result in [forward, inverse] {
                if cfg!(debug_assertions) {
                    let err = result.expect_err("a debug build asserts the shape");
                    let message = err.downcast_ref::<String>().map_or("", String::as_str);
                    assert_eq!(message, want);
                } else {
                    assert!(result.is_ok());
                }
            }
            if !cfg!(debug_assertions) {
                assert_eq!((g, h), (original.clone(), original));
            }
        }
    }

    #[test]
    fn inverse_line_skips_lengths_below_two() {
        struct Panics;
        impl Scheme<f64> for Panics {
            fn analyze(&self, _: &mut [f64], _: &mut [f64], _: usize) {
                unreachable!()
            }
            fn synthesize(&self, _: &mut [f64], _: &mut [f64], _: usize) {
                unreachable!()
            }
        }
        let mut line = [3.0];
        inverse_line(&mut line, &mut [0.0], [1, 1, 0].into_iter(), &Panics);
        assert_eq!(line, [3.0]);
    }
}
