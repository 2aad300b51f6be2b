//! The twin's seeded random numbers: ChaCha8 (`rand_chacha`), the one generator of the
//! project's simulators and tests (pam-synth uses it too), with the standard normal of
//! `rand_distr`. A seed gives the same run on every machine: ChaCha's stream is fixed by its
//! specification, not by the crate's version.
//!
//! The thin wrapper exists for [`Rng::derive`]: every consumer (an effect, the sensors, the
//! operator's path) draws from its own stream named by a string, so that switching one effect
//! on does not shift the numbers another one sees.

use rand::{Rng as _, RngCore, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;

#[derive(Clone, Debug)]
pub struct Rng(ChaCha8Rng);

impl Rng {
    pub fn new(seed: u64) -> Self {
        Rng(ChaCha8Rng::seed_from_u64(seed))
    }

    /// An independent stream for a named consumer: ChaCha's 64-bit stream number is a hash
    /// (FNV-1a) of the name.
    pub fn derive(seed: u64, name: &str) -> Self {
        let mut h: u64 = 0xCBF2_9CE4_8422_2325;
        for b in name.bytes() {
            h ^= b as u64;
            h = h.wrapping_mul(0x0000_0100_0000_01B3);
        }
        let mut r = ChaCha8Rng::seed_from_u64(seed);
        r.set_stream(h);
        Rng(r)
    }

    pub fn next_u64(&mut self) -> u64 {
        self.0.next_u64()
    }

    /// Uniform in [0, 1).
    pub fn uniform(&mut self) -> f64 {
        self.0.random::<f64>()
    }

    /// Standard normal.
    pub fn normal(&mut self) -> f64 {
        self.0.sample(StandardNormal)
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
        assert_ne!(draw(Rng::derive(7, "sensors")), draw(Rng::new(7)));
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
