//! One way to compare. Every error a test measures goes through these helpers, which fail the
//! test on a NaN or infinite operand and say where it was. A bare `f64::max` fold drops NaN
//! (`NaN.max(x)` is `x`), so a pass that wrote NaN everywhere would score a worst error of 0;
//! `tests/honest.rs` keeps such folds out of the tests.

use std::fmt::Debug;

/// `v`, failing the test where it is NaN or infinite (`what` and `at` name the value).
#[track_caller]
pub fn finite(v: f64, what: &str, at: &dyn Debug) -> f64 {
    assert!(v.is_finite(), "{what} is {v} at {at:?}");
    v
}

/// |a − b|, failing the test where either operand is not finite.
#[track_caller]
pub fn abs_err(a: impl Into<f64>, b: impl Into<f64>, at: impl Debug) -> f64 {
    let (a, b) = (a.into(), b.into());
    finite(a, "the actual value", &at);
    finite(b, "the expected value", &at);
    (a - b).abs()
}

/// |a − b| / max(|b|, floor), failing the test where either operand is not finite.
#[track_caller]
pub fn rel_err(a: impl Into<f64>, b: impl Into<f64>, floor: f64, at: impl Debug) -> f64 {
    let b = b.into();
    abs_err(a, b, &at) / b.abs().max(floor)
}

/// The largest of `values` (0 for none), failing the test on any that is not finite: the
/// NaN-safe `fold(0.0, f64::max)`.
#[track_caller]
pub fn max_of<V: Into<f64>>(values: impl IntoIterator<Item = V>) -> f64 {
    let mut top = 0.0f64;
    for (k, v) in values.into_iter().enumerate() {
        let v = finite(v.into(), "a value", &k);
        if v > top {
            top = v;
        }
    }
    top
}

/// The largest |v| of `values` (0 for none), failing the test on any that is not finite.
#[track_caller]
pub fn max_abs<V: Into<f64>>(values: impl IntoIterator<Item = V>) -> f64 {
    max_of(values.into_iter().map(|v| v.into().abs()))
}

/// The smallest of `values` (+∞ for none), failing the test on any that is not finite.
#[track_caller]
pub fn min_of<V: Into<f64>>(values: impl IntoIterator<Item = V>) -> f64 {
    -max_of_signed(values.into_iter().map(|v| -v.into()))
}

/// The largest of `values` (−∞ for none), failing the test on any that is not finite.
#[track_caller]
pub fn max_of_signed<V: Into<f64>>(values: impl IntoIterator<Item = V>) -> f64 {
    let mut top = f64::NEG_INFINITY;
    for (k, v) in values.into_iter().enumerate() {
        let v = finite(v.into(), "a value", &k);
        if v > top {
            top = v;
        }
    }
    top
}

/// Errors gathered over many places: the worst with where it was, the mean and the RMS. Each
/// error added must be finite (a NaN operand fails the test at its place).
#[derive(Clone, Debug)]
pub struct Errors<L> {
    worst: f64,
    at: Option<L>,
    sum: f64,
    sum_sq: f64,
    n: usize,
}

impl<L: Clone + Debug> Default for Errors<L> {
    fn default() -> Self {
        Errors::new()
    }
}

impl<L: Clone + Debug> Errors<L> {
    /// No errors yet (worst 0).
    pub fn new() -> Self {
        Errors {
            worst: 0.0,
            at: None,
            sum: 0.0,
            sum_sq: 0.0,
            n: 0,
        }
    }

    /// Adds the error `e` measured at `at`; fails the test where it is not finite. Returns `e`.
    #[track_caller]
    pub fn add(&mut self, e: f64, at: L) -> f64 {
        finite(e, "an error", &at);
        if self.at.is_none() || e > self.worst {
            self.worst = e;
            self.at = Some(at);
        }
        self.sum += e;
        self.sum_sq += e * e;
        self.n += 1;
        e
    }

    /// Adds |a − b| at `at` (see [`abs_err`]). Returns it.
    #[track_caller]
    pub fn abs(&mut self, a: impl Into<f64>, b: impl Into<f64>, at: L) -> f64 {
        let e = abs_err(a, b, &at);
        self.add(e, at)
    }

    /// Adds |a − b| / max(|b|, floor) at `at` (see [`rel_err`]). Returns it.
    #[track_caller]
    pub fn rel(&mut self, a: impl Into<f64>, b: impl Into<f64>, floor: f64, at: L) -> f64 {
        let e = rel_err(a, b, floor, &at);
        self.add(e, at)
    }

    /// Adds every error of `other`, keeping the worst's place.
    pub fn merge(&mut self, other: &Errors<L>) {
        if let Some(at) = &other.at {
            if other.worst > self.worst || self.at.is_none() {
                self.worst = other.worst;
                self.at = Some(at.clone());
            }
        }
        self.sum += other.sum;
        self.sum_sq += other.sum_sq;
        self.n += other.n;
    }

    /// The largest error (0 where none was added).
    pub fn worst(&self) -> f64 {
        self.worst
    }

    /// Where the largest error was.
    pub fn at(&self) -> Option<&L> {
        self.at.as_ref()
    }

    /// The mean error (0 where none was added).
    pub fn mean(&self) -> f64 {
        if self.n == 0 {
            0.0
        } else {
            self.sum / self.n as f64
        }
    }

    /// The root mean square error (0 where none was added).
    pub fn rms(&self) -> f64 {
        if self.n == 0 {
            0.0
        } else {
            (self.sum_sq / self.n as f64).sqrt()
        }
    }

    /// How many errors were added.
    pub fn count(&self) -> usize {
        self.n
    }

    /// Fails the test unless errors were added and the worst is at most `bound`, naming
    /// `what`, the worst and where it was.
    #[track_caller]
    pub fn assert_within(&self, bound: f64, what: &str) {
        assert!(self.n > 0, "{what}: nothing was compared");
        assert!(
            self.worst <= bound,
            "{what}: worst error {:e} > {bound:e} at {:?}",
            self.worst,
            self.at
        );
    }
}

/// Per-channel relative errors of frame `a` against frame `b` of the same size, with a floor
/// of 1e-3 for dark pixels: how two renders by the same passes on the same inputs are compared
/// (they agree to f32 rounding). A non-finite pixel fails the test at its place.
#[track_caller]
pub fn frame_errors(a: &envlight::EnvMap, b: &envlight::EnvMap) -> Errors<(usize, usize)> {
    assert_eq!((a.width, a.height), (b.width, b.height), "frame sizes");
    let mut errors = Errors::new();
    for (k, (x, y)) in a.texels.iter().zip(&b.texels).enumerate() {
        for c in 0..3 {
            errors.rel(x[c], y[c], 1e-3, (k, c));
        }
    }
    errors
}
