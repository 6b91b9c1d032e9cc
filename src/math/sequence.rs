//! Sample sequences shared bit for bit with `glsl/include/sequence.glsl`: the Hammersley set
//! filtered importance sampling uses, the per-pixel rotation that decorrelates it, and the
//! integer hash behind the Monte Carlo reference's random numbers.

/// Van der Corput radical inverse in base 2 of `i`, in [0, 1), to 24 bits (exact in float32,
/// so the GPU draws the same points).
pub fn radical_inverse(i: u32) -> f64 {
    (i.reverse_bits() >> 8) as f64 * (1.0 / 16_777_216.0)
}

/// Point `i` of the `n`-point Hammersley set: ((i + ½)/n, φ₂(i)). The half shift keeps the
/// first coordinate off 0 so that no sample has a zero pdf; for n = 2^m it is still a
/// (0, m, 2)-net.
pub fn hammersley(i: u32, n: u32) -> [f64; 2] {
    [(i as f64 + 0.5) / n as f64, radical_inverse(i)]
}

/// The PCG-RXS-M-XS output hash (Jarzynski & Olano 2020, "Hash functions for GPU rendering").
pub fn pcg(v: u32) -> u32 {
    let state = v.wrapping_mul(747_796_405).wrapping_add(2_891_336_453);
    let word = ((state >> ((state >> 28).wrapping_add(4))) ^ state).wrapping_mul(277_803_737);
    (word >> 22) ^ word
}

/// A uniform float in [0, 1) from the top 24 bits of `h` (exact in float32 as well).
pub fn unit(h: u32) -> f64 {
    (h >> 8) as f64 * (1.0 / 16_777_216.0)
}

/// The per-pixel Cranley–Patterson offset of pixel (x, y): two uniforms.
pub fn pixel_offset(x: u32, y: u32) -> [f64; 2] {
    let h = pcg(x.wrapping_add(pcg(y)));
    [unit(h), unit(pcg(h))]
}

/// Adds `offset` to `u` modulo 1 (the rotation of a sample set).
pub fn rotate(u: [f64; 2], offset: [f64; 2]) -> [f64; 2] {
    let f = |a: f64, b: f64| {
        let s = a + b;
        if s >= 1.0 {
            s - 1.0
        } else {
            s
        }
    };
    [f(u[0], offset[0]), f(u[1], offset[1])]
}

/// A stream of random numbers for one pixel, one sample and one seed: the Monte Carlo
/// reference draws its uniforms from it in a fixed order, on the GPU and here alike.
#[derive(Clone, Copy, Debug)]
pub struct Rng(u32);

impl Rng {
    /// The stream of pixel (x, y), sample `index`, seed `seed`.
    pub fn new(x: u32, y: u32, index: u32, seed: u32) -> Rng {
        Rng(pcg(
            pcg(pcg(x.wrapping_add(pcg(y))).wrapping_add(index)) ^ seed
        ))
    }

    /// The next uniform in [0, 1).
    pub fn uniform(&mut self) -> f64 {
        self.0 = pcg(self.0);
        unit(self.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hammersley_is_a_net() {
        // Every elementary interval of area 1/n holds exactly one point, for n = 2^m.
        for m in 0..9u32 {
            let n = 1u32 << m;
            for k in 0..=m {
                let (bx, by) = (1u32 << k, 1u32 << (m - k));
                let mut counts = vec![0u32; (bx * by) as usize];
                for i in 0..n {
                    let [a, b] = hammersley(i, n);
                    let cell = (b * by as f64) as u32 * bx + (a * bx as f64) as u32;
                    counts[cell as usize] += 1;
                }
                assert!(counts.iter().all(|&c| c == 1), "m={m} k={k}");
            }
        }
    }

    #[test]
    fn rng_is_uniform() {
        let mut sums = [0.0f64; 2];
        let n = 200_000;
        for i in 0..n {
            let mut r = Rng::new(i % 37, i / 37, i, 7);
            let u = r.uniform();
            assert!((0.0..1.0).contains(&u));
            sums[0] += u;
            sums[1] += u * u;
        }
        let mean = sums[0] / n as f64;
        let var = sums[1] / n as f64 - mean * mean;
        // Standard error of the mean is 0.29/√n ≈ 6.5e-4.
        assert!((mean - 0.5).abs() < 4e-3, "{mean}");
        assert!((var - 1.0 / 12.0).abs() < 2e-3, "{var}");
    }

    #[test]
    fn rotation_stays_in_unit_square() {
        let u = rotate([0.75, 0.999_999], [0.5, 0.000_002]);
        assert!(u.iter().all(|v| (0.0..1.0).contains(v)), "{u:?}");
    }
}
