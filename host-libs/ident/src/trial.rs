//! What a log gives the identification: time, encoder angles, measured force, and the
//! force reference when one is active. Everything else (handle position, velocity,
//! acceleration) is derived here through the robot's forward kinematics.

use crate::held_out::HeldOut;
use pam_model::RobotModel;
use pam_numerics::filter::Butterworth;
use pam_numerics::interp::linear_at;
use pam_numerics::stats::mean;
use rayon::prelude::*;

/// The columns of one trial, in SI units, user frame.
#[derive(Clone, Debug, Default)]
pub struct Trial {
    pub t_s: Vec<f64>,
    pub alpha_rad: [Vec<f64>; 2],
    /// Force the robot exerts on whatever holds the handle (log columns fx_n, fy_n).
    pub force_n: [Vec<f64>; 2],
    /// Force reference (fx_ref_n, fy_ref_n), present in step experiments.
    pub force_ref_n: Option<[Vec<f64>; 2]>,
    /// Commanded I/P currents i1..i4 (mA), when the log has them.
    pub current_ma: Option<[Vec<f64>; 4]>,
}

/// Settings of the derivative filter (thesis: 10th order Butterworth at 8 Hz).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FilterSettings {
    pub order: usize,
    pub cutoff_hz: f64,
}

impl Default for FilterSettings {
    fn default() -> Self {
        FilterSettings {
            order: 10,
            cutoff_hz: 8.0,
        }
    }
}

/// A trial with handle kinematics derived from the encoders.
#[derive(Clone, Debug)]
pub struct Prepared {
    pub t_s: Vec<f64>,
    pub dt_s: f64,
    pub alpha_rad: [Vec<f64>; 2],
    /// Handle position, user frame.
    pub x_m: [Vec<f64>; 2],
    /// Displacement from the equilibrium (the position at the start of the trial).
    pub dx_m: [Vec<f64>; 2],
    pub x0_m: [f64; 2],
    pub v_m_s: [Vec<f64>; 2],
    pub a_m_s2: [Vec<f64>; 2],
    pub force_n: [Vec<f64>; 2],
    pub force_ref_n: Option<[Vec<f64>; 2]>,
    /// Encoder angles low-passed like the derivatives (for direction-dependent effects,
    /// which must not flip on encoder quantisation).
    pub alpha_smooth_rad: [Vec<f64>; 2],
    /// Equilibrium joint angles (mean over the first 0.1 s, like `x0_m`).
    pub alpha0_rad: [f64; 2],
    pub current_ma: Option<[Vec<f64>; 4]>,
    /// The rows fits are scored on and not fitted to: the last 20 %, or in a step trial
    /// with enough steps every fifth step ([`HeldOut`]).
    pub held_out: HeldOut,
    /// The encoder angles as logged, at the logged times, when the log's sampling was
    /// uneven (dropped frames, jitter) and it was resampled to its median period by linear
    /// interpolation ([`Prepared::resampled`]; the encoders' counts are on a lattice there,
    /// not in the interpolated angles).
    pub logged_angles: Option<std::sync::Arc<LoggedAngles>>,
    /// Cutoff of the derivative filter actually used (≤ 0.45 × the sampling rate).
    pub cutoff_hz: f64,
}

/// Encoder angles at the log's own rows.
#[derive(Debug, Clone, PartialEq)]
pub struct LoggedAngles {
    pub t_s: Vec<f64>,
    pub alpha_rad: [Vec<f64>; 2],
}

impl Trial {
    /// The columns the identification uses, from a log (which has already been checked
    /// for malformed values by pam-log).
    pub fn from_log(log: &pam_log::Log) -> Result<Self, crate::IdentError> {
        use pam_log::col;
        let need = |name: &str| log.require(name).map(|c| c.to_vec());
        let force_ref_n = match (log.column(col::FX_REF_N), log.column(col::FY_REF_N)) {
            (Some(x), Some(y)) => Some([x.to_vec(), y.to_vec()]),
            (None, None) => None,
            (Some(x), None) => Some([x.to_vec(), vec![0.0; x.len()]]),
            (None, Some(y)) => Some([vec![0.0; y.len()], y.to_vec()]),
        };
        let current_ma = match col::CURRENTS_MA.map(|c| log.column(c)) {
            [Some(a), Some(b), Some(c), Some(d)] => {
                Some([a.to_vec(), b.to_vec(), c.to_vec(), d.to_vec()])
            }
            _ => None,
        };
        let trial = Trial {
            t_s: need(col::T_S)?,
            alpha_rad: [need(col::ALPHA1_RAD)?, need(col::ALPHA2_RAD)?],
            force_n: [need(col::FX_N)?, need(col::FY_N)?],
            force_ref_n,
            current_ma,
        };
        trial
            .validate()
            .map_err(|e| e.in_log(log.source.as_deref()))?;
        Ok(trial)
    }

    pub fn len(&self) -> usize {
        self.t_s.len()
    }
    pub fn is_empty(&self) -> bool {
        self.t_s.is_empty()
    }

    /// Checks lengths, finiteness and monotonic time (a log reader normally already did).
    pub fn validate(&self) -> Result<(), crate::IdentError> {
        let n = self.t_s.len();
        if n < 20 {
            return Err(crate::IdentError::TooFewSamples {
                samples: n,
                needed: 20,
            });
        }
        let mut cols: Vec<(&str, &Vec<f64>)> = vec![
            ("alpha1_rad", &self.alpha_rad[0]),
            ("alpha2_rad", &self.alpha_rad[1]),
            ("fx_n", &self.force_n[0]),
            ("fy_n", &self.force_n[1]),
        ];
        if let Some(r) = &self.force_ref_n {
            cols.push(("fx_ref_n", &r[0]));
            cols.push(("fy_ref_n", &r[1]));
        }
        for (name, c) in &cols {
            if c.len() != n {
                return Err(crate::IdentError::ColumnLength {
                    column: name,
                    len: c.len(),
                    expected: n,
                });
            }
            if let Some(i) = c.iter().position(|v| !v.is_finite()) {
                return Err(crate::IdentError::NotFinite {
                    column: name,
                    row: i + 1,
                });
            }
        }
        for i in 1..n {
            if !(self.t_s[i] > self.t_s[i - 1]) {
                return Err(crate::IdentError::TimeNotIncreasing { row: i + 1 });
            }
        }
        Ok(())
    }

    /// Positions by forward kinematics, velocities and accelerations by central differences
    /// followed by zero-phase Butterworth filtering (thesis §4.2, with high-order central
    /// instead of forward differences: no half-sample delay, no attenuation at 50 ms).
    pub fn prepare(
        &self,
        model: &RobotModel<f64>,
        filt: FilterSettings,
    ) -> Result<Prepared, crate::IdentError> {
        let mut each = self.prepare_each(model, &[filt])?;
        Ok(each.remove(0))
    }

    /// [`Trial::prepare`] with each of `filters`, on both cores: the validation, an uneven
    /// log's resampling, the forward kinematics and the raw velocity are computed once for
    /// all (the model loop tries three derivative cutoffs on a log of up to 1 kHz).
    pub fn prepare_each(
        &self,
        model: &RobotModel<f64>,
        filters: &[FilterSettings],
    ) -> Result<Vec<Prepared>, crate::IdentError> {
        self.prepare_rows(model, filters, true)
    }

    /// [`Trial::prepare`] on the log's own rows even when its sampling is uneven: for a
    /// step trial, whose model is simulated at the logged times (`response::Drive`), so a
    /// step stays where it was logged (resampling moves it by up to half a period and
    /// draws straight chords through the rises). The derivatives assume even sampling;
    /// a step trial does not use them.
    pub fn prepare_as_sampled(
        &self,
        model: &RobotModel<f64>,
        filt: FilterSettings,
    ) -> Result<Prepared, crate::IdentError> {
        let mut each = self.prepare_rows(model, &[filt], false)?;
        Ok(each.remove(0))
    }

    fn prepare_rows(
        &self,
        model: &RobotModel<f64>,
        filters: &[FilterSettings],
        resample_uneven: bool,
    ) -> Result<Vec<Prepared>, crate::IdentError> {
        self.validate()?;
        let uniform = if resample_uneven {
            self.resampled_if_uneven()
        } else {
            None
        };
        if let Some(uniform) = uniform {
            let mut each = uniform.prepare_each(model, filters)?;
            // shared by every preparation (one per filter setting tried)
            let logged = std::sync::Arc::new(LoggedAngles {
                t_s: self.t_s.clone(),
                alpha_rad: self.alpha_rad.clone(),
            });
            for p in &mut each {
                p.logged_angles = Some(logged.clone());
            }
            return Ok(each);
        }
        let n = self.len();
        let dt = (self.t_s[n - 1] - self.t_s[0]) / (n - 1) as f64;
        let mut x = [Vec::with_capacity(n), Vec::with_capacity(n)];
        for i in 0..n {
            let p = model
                .kinematics
                .forward_user([self.alpha_rad[0][i], self.alpha_rad[1][i]]);
            x[0].push(p[0]);
            x[1].push(p[1]);
        }
        let start = n.min(((0.1 / dt).round() as usize).max(1));
        let x0 = [mean(&x[0][..start]), mean(&x[1][..start])];
        let raw_v = [0, 1].map(|a| central_difference(&x[a], &self.t_s));
        let each: Vec<Result<Prepared, crate::IdentError>> = filters
            .par_iter()
            .map(|filt| self.filtered(&x, x0, &raw_v, start, *filt))
            .collect();
        // the first error in the filters' order, as a serial loop would give
        each.into_iter().collect()
    }

    /// The filtered signals of an evenly sampled trial whose positions `x` (their mean over
    /// the first `start` samples `x0`) and raw velocities `raw_v` are known.
    fn filtered(
        &self,
        x: &[Vec<f64>; 2],
        x0: [f64; 2],
        raw_v: &[Vec<f64>; 2],
        start: usize,
        filt: FilterSettings,
    ) -> Result<Prepared, crate::IdentError> {
        let n = self.len();
        let dt = (self.t_s[n - 1] - self.t_s[0]) / (n - 1) as f64;
        let fs = 1.0 / dt;
        let cutoff = filt.cutoff_hz.min(0.45 * fs);
        let bw = Butterworth::lowpass(filt.order, cutoff, fs)?;
        // each axis's filters in one chain (displacement, velocity, acceleration, angle),
        // the two axes on both cores
        let axis = |a: usize| {
            // the displacement through the same zero-phase low-pass as the derivatives: the
            // encoders' quantisation (white up to Nyquist) would otherwise reach the stiffness
            // regressor but not the measured force, and the base would spend terms (the
            // pneumatic high-pass) cancelling it instead of describing the arm
            let d: Vec<f64> = x[a].iter().map(|v| v - x0[a]).collect();
            let dx = bw.filtfilt(&d, fs, cutoff);
            let v = bw.filtfilt(&raw_v[a], fs, cutoff);
            let acc = bw.filtfilt(&central_difference(&v, &self.t_s), fs, cutoff);
            let smooth = bw.filtfilt(&self.alpha_rad[a], fs, cutoff);
            (dx, v, acc, smooth)
        };
        let ((dx0, v0, a0, s0), (dx1, v1, a1, s1)) = rayon::join(|| axis(0), || axis(1));
        let alpha0_rad = [
            mean(&self.alpha_rad[0][..start]),
            mean(&self.alpha_rad[1][..start]),
        ];
        Ok(Prepared {
            t_s: self.t_s.clone(),
            dt_s: dt,
            alpha_rad: self.alpha_rad.clone(),
            x_m: x.clone(),
            dx_m: [dx0, dx1],
            x0_m: x0,
            v_m_s: [v0, v1],
            a_m_s2: [a0, a1],
            force_n: self.force_n.clone(),
            force_ref_n: self.force_ref_n.clone(),
            alpha_smooth_rad: [s0, s1],
            alpha0_rad,
            current_ma: self.current_ma.clone(),
            held_out: HeldOut::last_fifth(n),
            logged_angles: None,
            cutoff_hz: cutoff,
        })
    }
}

impl Trial {
    /// A copy on a uniform grid at the median period when some period differs from it by
    /// more than 25 % (the derivatives assume even sampling); `None` when already even.
    pub fn resampled_if_uneven(&self) -> Option<Trial> {
        let n = self.len();
        let mut d: Vec<f64> = self.t_s.windows(2).map(|w| w[1] - w[0]).collect();
        d.sort_by(|a, b| a.total_cmp(b));
        let med = d[d.len() / 2];
        if d[0] >= 0.75 * med && d[d.len() - 1] <= 1.25 * med {
            return None;
        }
        let t0 = self.t_s[0];
        let m = ((self.t_s[n - 1] - t0) / med + 1e-6).floor() as usize + 1;
        let grid: Vec<f64> = (0..m).map(|k| t0 + k as f64 * med).collect();
        let interp = |v: &[f64]| linear_at(&self.t_s, v, &grid);
        Some(Trial {
            t_s: grid.clone(),
            alpha_rad: [interp(&self.alpha_rad[0]), interp(&self.alpha_rad[1])],
            force_n: [interp(&self.force_n[0]), interp(&self.force_n[1])],
            // references and currents are piecewise constant: hold the last value
            force_ref_n: self
                .force_ref_n
                .as_ref()
                .map(|r| [hold(&self.t_s, &r[0], &grid), hold(&self.t_s, &r[1], &grid)]),
            current_ma: self
                .current_ma
                .as_ref()
                .map(|c| [0, 1, 2, 3].map(|k| hold(&self.t_s, &c[k], &grid))),
        })
    }
}

fn hold(t: &[f64], v: &[f64], grid: &[f64]) -> Vec<f64> {
    let mut j = 0;
    grid.iter()
        .map(|&g| {
            while j + 1 < t.len() && t[j + 1] <= g + 1e-12 {
                j += 1;
            }
            v[j]
        })
        .collect()
}

impl Prepared {
    /// The log's sampling was uneven and it was resampled to its median period.
    pub fn resampled(&self) -> bool {
        self.logged_angles.is_some()
    }

    pub fn len(&self) -> usize {
        self.t_s.len()
    }

    /// Every `stride`-th sample (from the first): the signals are already low-passed far
    /// below the new Nyquist frequency (the derivative filter's cutoff is ≤ 0.45 × the
    /// original rate, 8 Hz by default), so only the force's noise is subsampled. The
    /// held-out part stays the last fifth.
    pub fn every(&self, stride: usize) -> Prepared {
        self.decimated(stride, false)
    }

    /// Like [`Prepared::every`], with the commands (force reference, currents) averaged over
    /// each new period instead of picked: the step model holds a sample's command until the
    /// next one, so the mean keeps where within the period a step happened (a picked step
    /// would move to the period's end, a delay of half a period on average).
    pub fn every_with_mean_commands(&self, stride: usize) -> Prepared {
        self.decimated(stride, true)
    }

    fn decimated(&self, stride: usize, mean_commands: bool) -> Prepared {
        if stride <= 1 {
            return self.clone();
        }
        let pick = |v: &Vec<f64>| v.iter().step_by(stride).copied().collect::<Vec<f64>>();
        let pick2 = |v: &[Vec<f64>; 2]| [pick(&v[0]), pick(&v[1])];
        let command = |v: &Vec<f64>| {
            if mean_commands {
                v.chunks(stride)
                    .map(|c| c.iter().sum::<f64>() / c.len() as f64)
                    .collect::<Vec<f64>>()
            } else {
                pick(v)
            }
        };
        let t_s = pick(&self.t_s);
        let n = t_s.len();
        Prepared {
            t_s,
            dt_s: self.dt_s * stride as f64,
            alpha_rad: pick2(&self.alpha_rad),
            x_m: pick2(&self.x_m),
            dx_m: pick2(&self.dx_m),
            x0_m: self.x0_m,
            v_m_s: pick2(&self.v_m_s),
            a_m_s2: pick2(&self.a_m_s2),
            force_n: pick2(&self.force_n),
            force_ref_n: self.force_ref_n.as_ref().map(|r| r.each_ref().map(command)),
            alpha_smooth_rad: pick2(&self.alpha_smooth_rad),
            alpha0_rad: self.alpha0_rad,
            current_ma: self.current_ma.as_ref().map(|c| c.each_ref().map(command)),
            held_out: HeldOut::last_fifth(n),
            logged_angles: self.logged_angles.clone(),
            cutoff_hz: self.cutoff_hz,
        }
    }
    pub fn is_empty(&self) -> bool {
        self.t_s.is_empty()
    }

    /// First row of the held-out tail: a dynamic trial's fits (normal equations,
    /// cross-validation folds) work on the rows before it ([`HeldOut::tail_start`]).
    pub fn split(&self) -> usize {
        self.held_out.tail_start()
    }
}

/// Derivative by the 7-point central difference (the 5- and 3-point ones near the ends):
/// its gain error is below 0.5 % up to a quarter of the Nyquist frequency, where the plain
/// central difference is already 10 % low — it matters at the thesis's 50 ms sampling.
/// Samples are assumed evenly spaced (the mean period of `t`).
pub fn central_difference(s: &[f64], t: &[f64]) -> Vec<f64> {
    let n = s.len();
    let mut d = vec![0.0; n];
    if n < 2 {
        return d;
    }
    let h = (t[n - 1] - t[0]) / (n - 1) as f64;
    for i in 0..n {
        d[i] = if i >= 3 && i + 3 < n {
            (s[i + 3] - 9.0 * s[i + 2] + 45.0 * s[i + 1] - 45.0 * s[i - 1] + 9.0 * s[i - 2]
                - s[i - 3])
                / (60.0 * h)
        } else if i >= 2 && i + 2 < n {
            (-s[i + 2] + 8.0 * s[i + 1] - 8.0 * s[i - 1] + s[i - 2]) / (12.0 * h)
        } else if i >= 1 && i + 1 < n {
            (s[i + 1] - s[i - 1]) / (2.0 * h)
        } else if i == 0 {
            (s[1] - s[0]) / h
        } else {
            (s[n - 1] - s[n - 2]) / h
        };
    }
    d
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn uneven_sampling_is_resampled_and_even_sampling_is_not() {
        let mut t: Vec<f64> = (0..200).map(|i| i as f64 * 0.01).collect();
        let even = Trial {
            t_s: t.clone(),
            alpha_rad: [t.iter().map(|x| 0.01 * x).collect(), vec![0.0; 200]],
            force_n: [t.clone(), vec![0.0; 200]],
            force_ref_n: None,
            current_ma: None,
        };
        assert!(even.resampled_if_uneven().is_none());
        // three dropped frames
        t.drain(50..53);
        let uneven = Trial {
            alpha_rad: [t.iter().map(|x| 0.01 * x).collect(), vec![0.0; t.len()]],
            force_n: [t.clone(), vec![0.0; t.len()]],
            t_s: t,
            force_ref_n: None,
            current_ma: None,
        };
        let r = uneven.resampled_if_uneven().expect("uneven");
        assert_eq!(r.len(), 200);
        // linear signals come back exactly
        for (i, f) in r.force_n[0].iter().enumerate() {
            assert!((f - i as f64 * 0.01).abs() < 1e-9);
        }
        let model = RobotModel::<f64>::thesis();
        assert!(uneven
            .prepare(&model, FilterSettings::default())
            .unwrap()
            .resampled());
    }
}
