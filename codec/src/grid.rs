//! A dense row-major 2-D array: the one container heights, coefficients and masks share.

use crate::error::ParamError;

/// Row-major `rows × cols` samples. Sizes are validated once at construction so that
/// algorithms can index without re-checking.
#[derive(Clone, Debug, PartialEq)]
pub struct Grid<T> {
    rows: usize,
    cols: usize,
    data: Vec<T>,
}

impl<T: Copy + Default> Grid<T> {
    /// A grid filled with `T::default()`.
    pub fn zeros(rows: usize, cols: usize) -> Self {
        Self {
            rows,
            cols,
            data: vec![T::default(); rows * cols],
        }
    }
}

impl<T> Grid<T> {
    /// Wraps `data` (row-major); fails when `data.len() != rows * cols`.
    pub fn new(rows: usize, cols: usize, data: Vec<T>) -> Result<Self, ParamError> {
        match rows.checked_mul(cols) {
            Some(n) if n == data.len() => Ok(Self { rows, cols, data }),
            _ => Err(ParamError::GridShape {
                rows,
                cols,
                len: data.len(),
            }),
        }
    }

    pub fn rows(&self) -> usize {
        self.rows
    }

    pub fn cols(&self) -> usize {
        self.cols
    }

    pub fn len(&self) -> usize {
        self.data.len()
    }

    pub fn is_empty(&self) -> bool {
        self.data.is_empty()
    }

    pub fn data(&self) -> &[T] {
        &self.data
    }

    pub fn data_mut(&mut self) -> &mut [T] {
        &mut self.data
    }

    pub fn into_data(self) -> Vec<T> {
        self.data
    }

    /// Element at (`row`, `col`). Panics when out of range: callers index inside sizes
    /// they validated.
    #[inline]
    pub fn get(&self, row: usize, col: usize) -> &T {
        debug_assert!(row < self.rows && col < self.cols);
        &self.data[row * self.cols + col]
    }

    #[inline]
    pub fn get_mut(&mut self, row: usize, col: usize) -> &mut T {
        debug_assert!(row < self.rows && col < self.cols);
        &mut self.data[row * self.cols + col]
    }

    /// One row as a slice.
    #[inline]
    pub fn row(&self, row: usize) -> &[T] {
        &self.data[row * self.cols..(row + 1) * self.cols]
    }

    #[inline]
    pub fn row_mut(&mut self, row: usize) -> &mut [T] {
        &mut self.data[row * self.cols..(row + 1) * self.cols]
    }

    /// Applies `f` to every element, keeping the shape.
    pub fn map<U>(&self, f: impl FnMut(&T) -> U) -> Grid<U> {
        Grid {
            rows: self.rows,
            cols: self.cols,
            data: self.data.iter().map(f).collect(),
        }
    }
}

impl Grid<f64> {
    /// The lowest and highest samples, NaN (no-data) skipped; `None` when nothing is left.
    pub fn min_max(&self) -> Option<(f64, f64)> {
        self.data
            .iter()
            .filter(|h| !h.is_nan())
            .fold(None, |acc, &h| match acc {
                None => Some((h, h)),
                Some((lo, hi)) => Some((h.min(lo), h.max(hi))),
            })
    }
}

impl<T: Copy> Grid<T> {
    /// The `size_r × size_c` window whose top-left sample is (`row`, `col`).
    pub fn crop(
        &self,
        row: usize,
        col: usize,
        size_r: usize,
        size_c: usize,
    ) -> Result<Self, ParamError> {
        let fits = |start: usize, len: usize, total: usize| {
            start.checked_add(len).is_some_and(|end| end <= total) && len > 0
        };
        if !fits(row, size_r, self.rows) || !fits(col, size_c, self.cols) {
            return Err(ParamError::Crop {
                row,
                col,
                size_r,
                size_c,
                rows: self.rows,
                cols: self.cols,
            });
        }
        let mut data = Vec::with_capacity(size_r * size_c);
        for r in row..row + size_r {
            data.extend_from_slice(&self.row(r)[col..col + size_c]);
        }
        Ok(Self {
            rows: size_r,
            cols: size_c,
            data,
        })
    }
}
