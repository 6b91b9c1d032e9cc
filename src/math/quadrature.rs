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

/// Length of an interval below which [`integrate_smooth`] uses the 4-point rule.
pub const SHORT: f64 = 1.0 / 16.0;

/// ∫ f over [a, b] for an `f` whose derivatives stay of order one on [a, b]: the 4-point rule
/// on intervals up to [`SHORT`] long (its error, (b − a)⁹·2.9e-7·max|f⁽⁸⁾| ≤ 4e-18·max|f⁽⁸⁾|,
/// is far below a double's rounding of the result), else [`integrate`]'s 16 points. A texel
/// edge of a map 32 or more texels wide takes the short rule: a quarter of the evaluations.
pub fn integrate_smooth(a: f64, b: f64, f: impl Fn(f64) -> f64) -> f64 {
    if (b - a).abs() > SHORT {
        return integrate(a, b, f);
    }
    let (mid, half) = (0.5 * (a + b), 0.5 * (b - a));
    let mut sum = 0.0;
    for (x, w) in GL4_NODES.iter().zip(GL4_WEIGHTS) {
        sum += w * (f(mid - half * x) + f(mid + half * x));
    }
    sum * half
}

/// The 4-point Gauss–Legendre rule's positive nodes, √(3/7 ∓ (2/7)√(6/5)).
const GL4_NODES: [f64; 2] = [0.339_981_043_584_856_3, 0.861_136_311_594_052_6];
/// Their weights, (18 ± √30)/36.
const GL4_WEIGHTS: [f64; 2] = [0.652_145_154_862_546_1, 0.347_854_845_137_453_9];

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

    /// The short rule's constants are the 4-point rule's, and on a short interval it agrees
    /// with the 16-point rule to rounding (an angular texel edge's integrand).
    #[test]
    fn the_short_rule_is_the_four_point_rule() {
        let (x, w) = gauss_legendre(4);
        for k in 0..2 {
            assert!((x[2 + k] - GL4_NODES[k]).abs() < 1e-15, "node {k}");
            assert!((w[2 + k] - GL4_WEIGHTS[k]).abs() < 1e-15, "weight {k}");
        }
        let f = |y: f64| {
            let r2 = 0.3 * 0.3 + y * y;
            0.3 * 2.0 * (0.5 * std::f64::consts::PI * r2.sqrt()).sin().powi(2) / r2
        };
        for (a, b) in [(0.1, 0.1 + SHORT), (-0.02, 0.01), (0.5, 0.5 + 1e-3)] {
            let (short, long) = (integrate_smooth(a, b, f), integrate(a, b, f));
            assert!(
                (short - long).abs() <= 1e-15 * long.abs(),
                "[{a}, {b}]: {short} vs {long}"
            );
        }
    }

    #[test]
    fn integrates_smooth_function() {
        let v = integrate(0.0, std::f64::consts::PI, f64::sin);
        assert!((v - 2.0).abs() < 1e-14, "{v}");
    }
}
