//! Gauss–Legendre quadrature on an interval.

use std::sync::OnceLock;

/// Number of Gauss–Legendre nodes used by [`integrate`].
pub const GL_ORDER: usize = 16;

/// Nodes and weights of the `n`-point Gauss–Legendre rule on [-1, 1], by Newton iteration on
/// the Legendre polynomial (accurate to a few ulps for n ≤ 64).
pub fn gauss_legendre(n: usize) -> (Vec<f64>, Vec<f64>) {
    assert!(n >= 1, "a quadrature rule needs at least one node");
    let mut nodes = vec![0.0; n];
    let mut weights = vec![0.0; n];
    for i in 0..n.div_ceil(2) {
        // Tricomi's initial guess for the i-th root.
        let mut x = (std::f64::consts::PI * (i as f64 + 0.75) / (n as f64 + 0.5)).cos();
        let mut dp = 1.0;
        for _ in 0..100 {
            let (p, d) = legendre_and_derivative(n, x);
            dp = d;
            let dx = p / d;
            x -= dx;
            if dx.abs() < 1e-16 {
                break;
            }
        }
        let (_, d) = legendre_and_derivative(n, x);
        dp = if d != 0.0 { d } else { dp };
        let w = 2.0 / ((1.0 - x * x) * dp * dp);
        nodes[i] = -x;
        nodes[n - 1 - i] = x;
        weights[i] = w;
        weights[n - 1 - i] = w;
    }
    (nodes, weights)
}

fn legendre_and_derivative(n: usize, x: f64) -> (f64, f64) {
    let (mut p0, mut p1) = (1.0, x);
    for k in 2..=n {
        let p2 = ((2 * k - 1) as f64 * x * p1 - (k - 1) as f64 * p0) / k as f64;
        p0 = p1;
        p1 = p2;
    }
    if n == 0 {
        return (1.0, 0.0);
    }
    (p1, n as f64 * (x * p1 - p0) / (x * x - 1.0))
}

fn rule() -> &'static (Vec<f64>, Vec<f64>) {
    static RULE: OnceLock<(Vec<f64>, Vec<f64>)> = OnceLock::new();
    RULE.get_or_init(|| gauss_legendre(GL_ORDER))
}

/// ∫ f over [a, b] with the [`GL_ORDER`]-point rule (exact for polynomials of degree 31).
pub fn integrate(a: f64, b: f64, f: impl Fn(f64) -> f64) -> f64 {
    let (nodes, weights) = rule();
    let (mid, half) = (0.5 * (a + b), 0.5 * (b - a));
    let sum: f64 = nodes
        .iter()
        .zip(weights)
        .map(|(x, w)| w * f(mid + half * x))
        .sum();
    sum * half
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn weights_sum_to_two_and_integrate_polynomials() {
        for n in [1, 2, 3, 4, 8, 16, 33] {
            let (x, w) = gauss_legendre(n);
            let s: f64 = w.iter().sum();
            assert!((s - 2.0).abs() < 1e-13, "n={n}: {s}");
            // x^(2n-2) is integrated exactly: 2/(2n-1).
            let p = 2 * n as i32 - 2;
            let i: f64 = x.iter().zip(&w).map(|(x, w)| w * x.powi(p)).sum();
            assert!((i - 2.0 / (p as f64 + 1.0)).abs() < 1e-12, "n={n}: {i}");
        }
    }

    #[test]
    fn integrates_smooth_function() {
        let v = integrate(0.0, std::f64::consts::PI, f64::sin);
        assert!((v - 2.0).abs() < 1e-14, "{v}");
    }
}
