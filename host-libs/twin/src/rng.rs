//! A small deterministic random generator (SplitMix64) so a seed gives the same run on every
//! machine and every build; no dependency whose stream could change between versions.
//!
//! Kept hand-written on purpose (issue 11): with ChaCha8 (`rand_chacha` 0.9) in its place,
//! pam-twin's tests passed but three of pam-ident's twin_loop tests failed on the new noise
//! and operator paths (a control at 50 ms named cable_slip; pose_dependence at 1 ms and
//! nonlinear_stiffness at point 3 not found). The model loop's sensitivity to the
//! realisation is the lead's to look at first.

#[derive(Clone, Debug)]
pub struct Rng {
    state: u64,
    /// Second normal deviate of the last Box–Muller pair.
    spare_normal: Option<f64>,
}

impl Rng {
    pub fn new(seed: u64) -> Self {
        Rng {
            state: seed ^ 0x9E37_79B9_7F4A_7C15,
            spare_normal: None,
        }
    }

    /// An independent stream for a named consumer (an effect, the operator path), so that
    /// switching one effect on does not shift the random numbers another one sees.
    pub fn derive(seed: u64, name: &str) -> Self {
        let mut h: u64 = 0xCBF2_9CE4_8422_2325;
        for b in name.bytes() {
            h ^= b as u64;
            h = h.wrapping_mul(0x0000_0100_0000_01B3);
        }
        Rng::new(seed.wrapping_mul(0x2545_F491_4F6C_DD1D) ^ h)
    }

    pub fn next_u64(&mut self) -> u64 {
        self.state = self.state.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.state;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in [0, 1).
    pub fn uniform(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }

    /// Standard normal (Box–Muller).
    pub fn normal(&mut self) -> f64 {
        if let Some(z) = self.spare_normal.take() {
            return z;
        }
        let u1 = self.uniform().max(1e-300);
        let u2 = self.uniform();
        let r = (-2.0 * u1.ln()).sqrt();
        let (s, c) = (2.0 * std::f64::consts::PI * u2).sin_cos();
        self.spare_normal = Some(r * s);
        r * c
    }
}

#[cfg(test)]
mod tests {
    use super::Rng;

    #[test]
    fn a_seed_repeats_and_named_streams_differ() {
        let draw = |mut r: Rng| [r.next_u64(), r.next_u64(), r.next_u64()];
        assert_eq!(draw(Rng::new(7)), draw(Rng::new(7)));
        assert_ne!(draw(Rng::new(7)), draw(Rng::new(8)));
        assert_eq!(
            draw(Rng::derive(7, "sensors")),
            draw(Rng::derive(7, "sensors"))
        );
        assert_ne!(
            draw(Rng::derive(7, "sensors")),
            draw(Rng::derive(7, "operator_path"))
        );
    }

    #[test]
    fn uniform_and_normal_have_their_moments() {
        let mut r = Rng::new(1);
        let n = 200_000;
        let u: Vec<f64> = (0..n).map(|_| r.uniform()).collect();
        assert!(u.iter().all(|&x| (0.0..1.0).contains(&x)));
        let mean = u.iter().sum::<f64>() / n as f64;
        assert!((mean - 0.5).abs() < 0.005, "uniform mean {mean}");
        let z: Vec<f64> = (0..n).map(|_| r.normal()).collect();
        let m = z.iter().sum::<f64>() / n as f64;
        let var = z.iter().map(|x| (x - m) * (x - m)).sum::<f64>() / n as f64;
        assert!(
            m.abs() < 0.01 && (var - 1.0).abs() < 0.02,
            "normal mean {m}, variance {var}"
        );
    }
}
