//! What a rig's recording adds that is not an effect of the robot: uneven sampling (a
//! LabVIEW loop at 30–40 ms), lost frames, heavy-tailed load-cell noise, isolated spikes
//! (a corrupted frame, a knock on the cable) and the ADC's quantisation of the force.
//!
//! A nuisance is not a label: a log with nuisances and no effect is still a control. They
//! draw from their own random stream, so the same seed with and without them shares the
//! motion, the effect and the noise's Gaussian draws, and a verdict that changes is the
//! nuisance's doing.

use rand::Rng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};
use serde::{Deserialize, Serialize};

use crate::error::SynthError;
use crate::signal::{log_uniform, Forces};

/// The nuisances of one log. `Default` is none of them.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Nuisances {
    /// Each sampling interval is the period times 1 ± this (uniform), on the generator's
    /// fine grid; 0 = even sampling.
    #[serde(default)]
    pub jitter: f64,
    /// Share of rows lost (their time is skipped, as a dropped telemetry frame).
    #[serde(default)]
    pub drop_rate: f64,
    /// The white load-cell noise is Student's t with 3 degrees of freedom (same standard
    /// deviation) instead of Gaussian.
    #[serde(default)]
    pub heavy_tails: bool,
    /// Share of rows whose force holds a spike of 8–40 times the noise (at least 2 N), on
    /// one axis or both.
    #[serde(default)]
    pub spike_rate: f64,
    /// The logged force is rounded to this step (N); 0 = not quantised.
    #[serde(default)]
    pub force_lsb_n: f64,
}

/// How `--nuisance` chooses a case's nuisances.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum NuisancePlan {
    /// The same nuisances for every log.
    Fixed(Nuisances),
    /// Drawn per log from its seed ([`Nuisances::random`]).
    Random,
}

impl NuisancePlan {
    /// `none`, `random`, or a comma list of `jitter=J`, `drops=R`, `heavy_tails`,
    /// `spikes=R`, `lsb=N`.
    pub fn parse(s: &str) -> Result<Self, SynthError> {
        match s {
            "none" => return Ok(NuisancePlan::Fixed(Nuisances::default())),
            "random" => return Ok(NuisancePlan::Random),
            _ => {}
        }
        let mut n = Nuisances::default();
        for item in s.split(',').map(str::trim).filter(|x| !x.is_empty()) {
            let (key, value) = match item.split_once('=') {
                Some((k, v)) => (k, Some(v)),
                None => (item, None),
            };
            let number = |v: Option<&str>| -> Result<f64, SynthError> {
                let v = v.ok_or_else(|| bad(item))?;
                let x: f64 = v.parse().map_err(|_| bad(item))?;
                if x.is_finite() && x >= 0.0 {
                    Ok(x)
                } else {
                    Err(bad(item))
                }
            };
            match key {
                "jitter" => n.jitter = number(value)?,
                "drops" => n.drop_rate = number(value)?,
                "spikes" => n.spike_rate = number(value)?,
                "lsb" => n.force_lsb_n = number(value)?,
                "heavy_tails" if value.is_none() => n.heavy_tails = true,
                _ => return Err(bad(item)),
            }
        }
        n.validate()?;
        Ok(NuisancePlan::Fixed(n))
    }

    /// The nuisances of the case with this seed.
    pub fn for_seed(&self, seed: u64) -> Nuisances {
        match self {
            NuisancePlan::Fixed(n) => *n,
            NuisancePlan::Random => Nuisances::random(seed),
        }
    }
}

fn bad(item: &str) -> SynthError {
    SynthError::UnknownName {
        what: "nuisance",
        name: item.to_string(),
        choices: "none, random, or a list of jitter=J (0–0.5), drops=R (0–0.2), heavy_tails, \
                  spikes=R (0–0.05), lsb=N (0–2)"
            .into(),
    }
}

/// The random stream of the nuisances (the generator's others are 1–3).
pub const STREAM_NUISANCE: u64 = 4;

impl Nuisances {
    /// A rig-like draw: each nuisance on with probability 0.4, at a size drawn on a log
    /// scale (jitter 5–30 %, drops 0.2–3 %, spikes 0.01–0.3 % of rows, an LSB of 0.02–0.3 N).
    pub fn random(seed: u64) -> Self {
        let mut rng = crate::rng(seed, STREAM_NUISANCE + 16);
        let mut on = || rng.random::<f64>() < 0.4;
        let (j, d, h, s, q) = (on(), on(), on(), on(), on());
        let mut rng = crate::rng(seed, STREAM_NUISANCE + 17);
        Nuisances {
            jitter: if j {
                log_uniform(&mut rng, 0.05, 0.3)
            } else {
                0.0
            },
            drop_rate: if d {
                log_uniform(&mut rng, 0.002, 0.03)
            } else {
                0.0
            },
            heavy_tails: h,
            spike_rate: if s {
                log_uniform(&mut rng, 1e-4, 3e-3)
            } else {
                0.0
            },
            force_lsb_n: if q {
                log_uniform(&mut rng, 0.02, 0.3)
            } else {
                0.0
            },
        }
    }

    pub fn is_none(&self) -> bool {
        *self == Nuisances::default()
    }

    pub fn validate(&self) -> Result<(), SynthError> {
        let ok = (0.0..=0.5).contains(&self.jitter)
            && (0.0..=0.2).contains(&self.drop_rate)
            && (0.0..=0.05).contains(&self.spike_rate)
            && (0.0..=2.0).contains(&self.force_lsb_n);
        if ok {
            Ok(())
        } else {
            Err(bad(&format!("{self:?}")))
        }
    }

    /// The fine-grid index of every loop iteration: `n` iterations `per` fine steps apart,
    /// moved by the jitter; never past `fine_len`. A step trial's commands change at these.
    pub fn iteration_indices(
        &self,
        n: usize,
        per: usize,
        fine_len: usize,
        rng: &mut ChaCha8Rng,
    ) -> Vec<usize> {
        let last = fine_len.saturating_sub(1);
        let mut idx = Vec::with_capacity(n);
        let mut at = 0usize;
        for _ in 0..n {
            if at > last {
                break;
            }
            idx.push(at);
            let step = if self.jitter > 0.0 && per > 1 {
                let f = 1.0 + self.jitter * (2.0 * rng.random::<f64>() - 1.0);
                ((per as f64 * f).round() as usize).max(1)
            } else {
                per
            };
            at += step;
        }
        idx
    }

    /// The iterations that reach the log: the drops thin them (never the first).
    pub fn logged_rows(&self, iterations: &[usize], rng: &mut ChaCha8Rng) -> Vec<usize> {
        if self.drop_rate == 0.0 {
            return iterations.to_vec();
        }
        iterations
            .iter()
            .enumerate()
            .filter(|(k, _)| *k == 0 || rng.random::<f64>() >= self.drop_rate)
            .map(|(_, &i)| i)
            .collect()
    }

    /// The factor on one Gaussian draw of the white load-cell noise: 1, or for heavy tails
    /// 1/√(χ²₃/3)/√3, which makes it Student's t (ν = 3) at the same standard deviation.
    /// Drawn from this stream, so the Gaussian draws stay those of the case without it.
    pub fn white_scale(&self, rng: &mut ChaCha8Rng) -> f64 {
        if !self.heavy_tails {
            return 1.0;
        }
        let chi2: f64 = (0..3)
            .map(|_| {
                let g: f64 = StandardNormal.sample(rng);
                g * g
            })
            .sum();
        1.0 / (chi2 / 3.0).max(1e-12).sqrt() / 3f64.sqrt()
    }

    /// Adds the spikes and rounds to the LSB, in place.
    pub fn corrupt(&self, force: &mut Forces, noise_n: f64, rng: &mut ChaCha8Rng) {
        if self.spike_rate > 0.0 {
            let size = noise_n.max(0.05);
            for f in force.iter_mut() {
                if rng.random::<f64>() >= self.spike_rate {
                    continue;
                }
                let height = (size * rng.random_range(8.0..40.0)).max(2.0);
                let sign = if rng.random::<bool>() { 1.0 } else { -1.0 };
                match rng.random_range(0..3) {
                    0 => f[0] += sign * height,
                    1 => f[1] += sign * height,
                    _ => {
                        f[0] += sign * height;
                        f[1] -= sign * height * rng.random_range(0.3..1.0);
                    }
                }
            }
        }
        if self.force_lsb_n > 0.0 {
            let q = self.force_lsb_n;
            for f in force.iter_mut() {
                *f = f.map(|x| (x / q).round() * q);
            }
        }
    }

    /// A short description for a log's line (`-` when none).
    pub fn describe(&self) -> String {
        let mut parts = Vec::new();
        if self.jitter > 0.0 {
            parts.push(format!("jitter {:.0}%", self.jitter * 100.0));
        }
        if self.drop_rate > 0.0 {
            parts.push(format!("drops {:.1}%", self.drop_rate * 100.0));
        }
        if self.heavy_tails {
            parts.push("t3".to_string());
        }
        if self.spike_rate > 0.0 {
            parts.push(format!("spikes {:.2}%", self.spike_rate * 100.0));
        }
        if self.force_lsb_n > 0.0 {
            parts.push(format!("lsb {:.2}N", self.force_lsb_n));
        }
        if parts.is_empty() {
            "-".into()
        } else {
            parts.join(" ")
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parse_lists_and_rejects_what_it_does_not_know() {
        let NuisancePlan::Fixed(n) = NuisancePlan::parse("jitter=0.2,heavy_tails,lsb=0.1").unwrap()
        else {
            panic!("a list is a fixed plan");
        };
        assert_eq!(n.jitter, 0.2);
        assert!(n.heavy_tails);
        assert_eq!(n.force_lsb_n, 0.1);
        assert_eq!(NuisancePlan::parse("random").unwrap(), NuisancePlan::Random);
        assert!(NuisancePlan::parse("jitter").is_err());
        assert!(NuisancePlan::parse("jitter=0.9").is_err());
        assert!(NuisancePlan::parse("wobble=1").is_err());
    }

    #[test]
    fn indices_keep_the_mean_period_and_drop_rows() {
        let mut rng = crate::rng(7, STREAM_NUISANCE);
        let n = Nuisances {
            jitter: 0.25,
            drop_rate: 0.05,
            ..Default::default()
        };
        let it = n.iteration_indices(10_000, 20, 1_000_000, &mut rng);
        let idx = n.logged_rows(&it, &mut rng);
        assert!(idx.windows(2).all(|w| w[1] > w[0]));
        let kept = idx.len() as f64 / 10_000.0;
        assert!((kept - 0.95).abs() < 0.01, "{kept}");
        let gaps: Vec<usize> = idx.windows(2).map(|w| w[1] - w[0]).collect();
        assert!(gaps.iter().any(|&g| g != 20 && g < 40));
        let span = *idx.last().unwrap() as f64 / 9_999.0;
        assert!((span - 20.0).abs() < 0.5, "{span}");
        // none: the even grid
        let even = Nuisances::default().iteration_indices(5, 20, 1_000, &mut rng);
        assert_eq!(even, vec![0, 20, 40, 60, 80]);
    }

    #[test]
    fn heavy_tails_keep_the_deviation() {
        let mut rng = crate::rng(3, STREAM_NUISANCE);
        let n = Nuisances {
            heavy_tails: true,
            ..Default::default()
        };
        let mut gauss = crate::rng(4, 1);
        let w: Vec<[f64; 2]> = (0..200_000)
            .map(|_| {
                let z: f64 = StandardNormal.sample(&mut gauss);
                [0.5 * z * n.white_scale(&mut rng), 0.0]
            })
            .collect();
        let var = w.iter().map(|f| f[0] * f[0]).sum::<f64>() / w.len() as f64;
        // t3's sample variance converges slowly (infinite fourth moment)
        assert!((var.sqrt() - 0.5).abs() < 0.08, "{}", var.sqrt());
        let beyond = w.iter().filter(|f| f[0].abs() > 2.5).count() as f64 / w.len() as f64;
        // a Gaussian of σ 0.5 has 5.7e-7 of its mass beyond 5σ; t3 far more
        assert!(beyond > 1e-3, "{beyond}");
    }
}
