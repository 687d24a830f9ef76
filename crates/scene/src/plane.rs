//! [`Plane`]: a dense row-major 2D array, the storage of every per-pixel map
//! (label maps, depth, edge strength, masks).

/// A `height × width` array stored row-major: element `(x, y)` is at `data[y * width + x]`.
/// `x` is the column (pixel u), `y` the row (pixel v); see `CONVENTIONS.md`.
#[derive(Clone, Debug, PartialEq)]
pub struct Plane<T> {
    /// Number of columns.
    pub width: usize,
    /// Number of rows.
    pub height: usize,
    /// `[height * width]`, row-major.
    pub data: Vec<T>,
}

impl<T: Clone> Plane<T> {
    /// A plane filled with `value`.
    pub fn filled(width: usize, height: usize, value: T) -> Self {
        Plane { width, height, data: vec![value; width * height] }
    }
}

impl<T> Plane<T> {
    /// Wraps `data` (`[height * width]`, row-major). Returns `None` if the length disagrees.
    pub fn from_vec(width: usize, height: usize, data: Vec<T>) -> Option<Self> {
        (data.len() == width * height).then_some(Plane { width, height, data })
    }

    /// Linear index of `(x, y)`.
    #[inline]
    pub fn index(&self, x: usize, y: usize) -> usize {
        debug_assert!(x < self.width && y < self.height);
        y * self.width + x
    }

    /// Element at column `x`, row `y`.
    #[inline]
    pub fn get(&self, x: usize, y: usize) -> &T {
        &self.data[y * self.width + x]
    }

    /// Mutable element at column `x`, row `y`.
    #[inline]
    pub fn get_mut(&mut self, x: usize, y: usize) -> &mut T {
        &mut self.data[y * self.width + x]
    }

    /// Row `y` as a slice of length `width`.
    pub fn row(&self, y: usize) -> &[T] {
        &self.data[y * self.width..(y + 1) * self.width]
    }

    /// `(width, height)`.
    pub fn size(&self) -> (usize, usize) {
        (self.width, self.height)
    }

    /// Applies `f` to every element.
    pub fn map<U>(&self, f: impl FnMut(&T) -> U) -> Plane<U> {
        Plane { width: self.width, height: self.height, data: self.data.iter().map(f).collect() }
    }
}
