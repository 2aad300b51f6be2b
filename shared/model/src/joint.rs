//! One antagonistic joint: direct model (P1, P2 → τ, K; eq. 3.2, 3.6, B.6, B.7), inverse
//! model (τ, K → P1, P2; App. B) and the capability quadrilateral (Table 3.2).

use crate::muscle::MuscleTerms;
use crate::params::{JointParams, MuscleCoeffs, PressureLimits};
use crate::real::Real;

/// Per-joint constants derived once from the parameters (not stored in the parameters:
/// one place for each fact).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct JointConsts<R> {
    pub epsilon0: R,
    pub pulley_radius_m: R,
    /// R / l0: contraction ratio per radian.
    pub epsilon_per_rad: R,
    /// R² / l0, the factor of eq. 3.6.
    pub stiffness_scale_m: R,
    /// F(ε0, P_pretension): the minimum cable force that keeps the cables engaged (§3.2).
    pub anti_slack_force_n: R,
    pub alpha_min_rad: R,
    pub alpha_max_rad: R,
    pub pressure_min_bar: R,
    pub pressure_max_bar: R,
}

impl<R: Real> JointConsts<R> {
    pub fn new(
        joint: &JointParams<R>,
        muscle: &MuscleCoeffs<R>,
        limits: &PressureLimits<R>,
    ) -> Self {
        let epsilon0 = joint.epsilon0();
        let r = joint.pulley_radius_m;
        let l0 = joint.muscle_rest_length_m;
        JointConsts {
            epsilon0,
            pulley_radius_m: r,
            epsilon_per_rad: r / l0,
            stiffness_scale_m: r * r / l0,
            anti_slack_force_n: muscle.force_n(epsilon0, joint.pretension_pressure_bar),
            alpha_min_rad: joint.alpha_min_rad,
            alpha_max_rad: joint.alpha_max_rad,
            pressure_min_bar: limits.min_bar,
            pressure_max_bar: limits.max_bar,
        }
    }

    /// ε1, ε2 at joint angle α (eq. 2.9).
    #[inline]
    pub fn epsilons(&self, alpha_rad: R) -> [R; 2] {
        let d = self.epsilon_per_rad * alpha_rad;
        [self.epsilon0 - d, self.epsilon0 + d]
    }

    /// Evaluates both muscles at α; everything else at this pose is linear in pressure.
    #[inline]
    pub fn pose(&self, muscle: &MuscleCoeffs<R>, alpha_rad: R) -> JointPose<R> {
        let eps = self.epsilons(alpha_rad);
        JointPose {
            alpha_rad,
            epsilon: eps,
            muscles: [muscle.terms(eps[0]), muscle.terms(eps[1])],
            pulley_radius_m: self.pulley_radius_m,
            stiffness_scale_m: self.stiffness_scale_m,
        }
    }
}

/// A joint evaluated at one angle.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct JointPose<R> {
    pub alpha_rad: R,
    pub epsilon: [R; 2],
    pub muscles: [MuscleTerms<R>; 2],
    pulley_radius_m: R,
    stiffness_scale_m: R,
}

impl<R: Real> JointPose<R> {
    /// τ = R (F2 − F1) (eq. 3.2), pressures `[P1, P2]` of the model's muscles 1 and 2.
    #[inline]
    pub fn torque_nm(&self, pressure_bar: [R; 2]) -> R {
        self.pulley_radius_m
            * (self.muscles[1].force_n(pressure_bar[1]) - self.muscles[0].force_n(pressure_bar[0]))
    }

    /// τ as the cables transmit it: each muscle's force floored at zero. Eq. 3.1 gives a
    /// negative force (a push) to a muscle stretched little at a low pressure, whose cable
    /// goes slack instead and transmits nothing. Equal to [`JointPose::torque_nm`] while both
    /// muscles pull.
    #[inline]
    pub fn cable_torque_nm(&self, pressure_bar: [R; 2]) -> R {
        let f = self.forces_n(pressure_bar);
        self.pulley_radius_m * (f[1].max(R::ZERO) - f[0].max(R::ZERO))
    }

    /// K = −(R²/l0)(∂F1/∂ε1 + ∂F2/∂ε2) (eq. 3.6, B.7).
    #[inline]
    pub fn stiffness_nm_per_rad(&self, pressure_bar: [R; 2]) -> R {
        -self.stiffness_scale_m
            * (self.muscles[0].dforce_depsilon_n(pressure_bar[0])
                + self.muscles[1].dforce_depsilon_n(pressure_bar[1]))
    }

    /// The muscle forces `[F1, F2]` in N.
    #[inline]
    pub fn forces_n(&self, pressure_bar: [R; 2]) -> [R; 2] {
        [
            self.muscles[0].force_n(pressure_bar[0]),
            self.muscles[1].force_n(pressure_bar[1]),
        ]
    }

    /// Exact solution of eq. B.6–B.7 for the pressures, with no limits applied.
    ///
    /// App. B eliminates P1 by hand (eq. B.8–B.9); the printed B.8 drops a factor R²/l0 and
    /// a sign, so this solves the same 2×2 linear system by Cramer's rule instead.
    /// `None` if the system is singular at this pose (it is not anywhere in the thesis's
    /// range, but a user calibration could make it so).
    #[inline]
    pub fn pressures_for(&self, torque_nm: R, stiffness_nm_per_rad: R) -> Option<[R; 2]> {
        let [m1, m2] = &self.muscles;
        // −A1·P1 + A2·P2 = τ/R − (B2 − B1)
        let t = torque_nm / self.pulley_radius_m - (m2.b_n - m1.b_n);
        //  C1·P1 + C2·P2 = −K/(R²/l0) − (D1 + D2)
        let k = -stiffness_nm_per_rad / self.stiffness_scale_m - (m1.d_n + m2.d_n);
        let det = -m1.a_n_per_bar * m2.c_n_per_bar - m2.a_n_per_bar * m1.c_n_per_bar;
        let scale =
            (m1.a_n_per_bar * m2.c_n_per_bar).abs() + (m2.a_n_per_bar * m1.c_n_per_bar).abs();
        if !(det.abs() > scale * R::from_f64(1e-6)) {
            return None;
        }
        let p1 = (t * m2.c_n_per_bar - m2.a_n_per_bar * k) / det;
        let p2 = (-m1.a_n_per_bar * k - m1.c_n_per_bar * t) / det;
        Some([p1, p2])
    }

    /// The capability quadrilateral at this pose (Table 3.2, generalised to either sign of
    /// α: at α ≠ 0 the two torque extremes have different stiffness).
    pub fn capability(&self, consts: &JointConsts<R>) -> Capability<R> {
        let (p_lo, p_hi) = (consts.pressure_min_bar, consts.pressure_max_bar);
        let clamp_p = |p: R| p.clamp_to(p_lo, p_hi);
        // K_min: zero torque, both cables at the anti-slack force.
        let p_kmin = consts.pretension_pressure_bar(self);
        // K_max: zero torque, the muscle that needs more pressure at the limit.
        let f_common = self.muscles[0]
            .force_n(p_hi)
            .min(self.muscles[1].force_n(p_hi));
        let p_kmax = [
            clamp_p(self.muscles[0].pressure_for_force_bar(f_common)),
            clamp_p(self.muscles[1].pressure_for_force_bar(f_common)),
        ];
        let p_tau_max = [p_lo, p_hi];
        let p_tau_min = [p_hi, p_lo];
        let vertex = |p: [R; 2]| Vertex {
            torque_nm: self.torque_nm(p),
            stiffness_nm_per_rad: self.stiffness_nm_per_rad(p),
            pressure_bar: p,
        };
        Capability {
            k_min: vertex(p_kmin),
            tau_max: vertex(p_tau_max),
            k_max: vertex(p_kmax),
            tau_min: vertex(p_tau_min),
        }
    }
}

/// One corner of the capability quadrilateral.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Vertex<R> {
    pub torque_nm: R,
    pub stiffness_nm_per_rad: R,
    pub pressure_bar: [R; 2],
}

/// The locus of attainable (τ, K) at one pose (Fig. 3.2–3.4): a quadrilateral because the
/// map from pressures to (τ, K) is affine at a fixed pose.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Capability<R> {
    /// (0, K_min): both cables at the anti-slack force.
    pub k_min: Vertex<R>,
    /// (τ_max, K): P1 at the lower limit, P2 at the upper.
    pub tau_max: Vertex<R>,
    /// (0, K_max): one muscle at the upper limit, zero torque.
    pub k_max: Vertex<R>,
    /// (τ_min, K): P1 at the upper limit, P2 at the lower.
    pub tau_min: Vertex<R>,
}

impl<R: Real> Capability<R> {
    /// The two stiffness levels of the thesis's trials at zero torque (§4.2):
    /// K_low = K_min, K_high = K_max − 0.2 (K_max − K_min).
    pub fn trial_stiffness_levels(&self) -> (R, R) {
        let (lo, hi) = (
            self.k_min.stiffness_nm_per_rad,
            self.k_max.stiffness_nm_per_rad,
        );
        (lo, hi - R::from_f64(0.2) * (hi - lo))
    }

    /// Corners in order around the quadrilateral.
    pub fn vertices(&self) -> [Vertex<R>; 4] {
        [self.k_min, self.tau_max, self.k_max, self.tau_min]
    }

    /// The stiffness range attainable at torque τ, or `None` if τ itself is out of reach.
    pub fn stiffness_range(&self, torque_nm: R) -> Option<(R, R)> {
        self.slice(torque_nm, |v| (v.torque_nm, v.stiffness_nm_per_rad))
    }

    /// The torque range attainable at stiffness K, or `None` if K is out of reach.
    pub fn torque_range(&self, stiffness_nm_per_rad: R) -> Option<(R, R)> {
        self.slice(stiffness_nm_per_rad, |v| {
            (v.stiffness_nm_per_rad, v.torque_nm)
        })
    }

    /// Intersects the line `key(v) = at` with the quadrilateral and returns the range of
    /// the other coordinate along it.
    fn slice(&self, at: R, key: impl Fn(&Vertex<R>) -> (R, R)) -> Option<(R, R)> {
        if !at.is_finite() {
            return None;
        }
        let v = self.vertices();
        let mut lo: Option<R> = None;
        let mut hi: Option<R> = None;
        for i in 0..4 {
            let (x0, y0) = key(&v[i]);
            let (x1, y1) = key(&v[(i + 1) % 4]);
            let (xa, xb) = if x0 <= x1 { (x0, x1) } else { (x1, x0) };
            if at < xa || at > xb {
                continue;
            }
            let y = if xb - xa > R::ZERO {
                y0 + (y1 - y0) * (at - x0) / (x1 - x0)
            } else {
                y0.min(y1)
            };
            let y_other = if xb - xa > R::ZERO { y } else { y0.max(y1) };
            lo = Some(match lo {
                Some(l) => l.min(y).min(y_other),
                None => y.min(y_other),
            });
            hi = Some(match hi {
                Some(h) => h.max(y).max(y_other),
                None => y.max(y_other),
            });
        }
        match (lo, hi) {
            (Some(l), Some(h)) => Some((l, h)),
            _ => None,
        }
    }

    pub fn torque_limits_nm(&self) -> (R, R) {
        let v = self.vertices();
        let mut lo = v[0].torque_nm;
        let mut hi = v[0].torque_nm;
        for x in &v[1..] {
            lo = lo.min(x.torque_nm);
            hi = hi.max(x.torque_nm);
        }
        (lo, hi)
    }

    /// Whether (τ, K) lies inside the quadrilateral (boundary included, within `tol`
    /// relative to the local stiffness range).
    pub fn contains(&self, torque_nm: R, stiffness_nm_per_rad: R) -> bool {
        match self.stiffness_range(torque_nm) {
            Some((lo, hi)) => {
                let tol = (hi - lo).abs() * R::from_f64(1e-6) + R::from_f64(1e-9);
                stiffness_nm_per_rad >= lo - tol && stiffness_nm_per_rad <= hi + tol
            }
            None => false,
        }
    }

    /// The attainable request nearest to (τ, K), torque first: τ is clamped to
    /// [τ_min, τ_max], then K to the stiffness range at that τ. Torque comes first because
    /// it is the force the patient feels now; stiffness only shapes how it changes.
    pub fn clamp(&self, torque_nm: R, stiffness_nm_per_rad: R) -> (R, R, Limited) {
        let mut flags = Limited::NONE;
        let (t_lo, t_hi) = self.torque_limits_nm();
        let torque = if torque_nm.is_finite() {
            torque_nm
        } else {
            R::ZERO
        };
        let t = torque.clamp_to(t_lo, t_hi);
        if t != torque_nm {
            flags = flags.with(Limited::TORQUE);
        }
        let (k_lo, k_hi) = match self.stiffness_range(t) {
            Some(r) => r,
            None => (
                self.k_min.stiffness_nm_per_rad,
                self.k_min.stiffness_nm_per_rad,
            ),
        };
        let stiff = if stiffness_nm_per_rad.is_finite() {
            stiffness_nm_per_rad
        } else {
            k_lo
        };
        let k = stiff.clamp_to(k_lo, k_hi);
        if k != stiffness_nm_per_rad {
            flags = flags.with(Limited::STIFFNESS);
        }
        (t, k, flags)
    }
}

/// What the inverse model had to change to make a request attainable. Never silent: every
/// change sets a bit.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Limited(pub u8);

impl Limited {
    pub const NONE: Limited = Limited(0);
    /// The torque was outside [τ_min, τ_max] at this pose.
    pub const TORQUE: Limited = Limited(1);
    /// The stiffness was outside the range attainable at the (clamped) torque.
    pub const STIFFNESS: Limited = Limited(2);
    /// The solved pressures left the pressure limits (numerical edge) and were clamped.
    pub const PRESSURE: Limited = Limited(4);
    /// An input was NaN/∞ or the pose was out of range: the safe pretension was returned.
    pub const INVALID_INPUT: Limited = Limited(8);
    /// The linear system was singular: the safe pretension was returned.
    pub const SINGULAR: Limited = Limited(16);
    /// The closed force loop's target was beyond what the muscles can give at this pose and
    /// was scaled down to it, its direction kept (`RobotModel::reachable_force_scale`).
    pub const TARGET: Limited = Limited(32);

    #[inline]
    pub const fn with(self, other: Limited) -> Limited {
        Limited(self.0 | other.0)
    }
    #[inline]
    pub const fn contains(self, other: Limited) -> bool {
        self.0 & other.0 == other.0 && other.0 != 0
    }
    #[inline]
    pub const fn is_none(self) -> bool {
        self.0 == 0
    }
}

/// Result of the inverse model for one joint.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct InverseSolution<R> {
    /// `[P1, P2]` of the model's muscles (map to channels with the joint's channel map).
    pub pressure_bar: [R; 2],
    /// The torque and stiffness these pressures give (equal to the request unless clamped).
    pub torque_nm: R,
    pub stiffness_nm_per_rad: R,
    pub limited: Limited,
}

impl<R: Real> JointConsts<R> {
    /// Inverse model with the feasibility check: (α, τ, K) → (P1, P2). An unattainable
    /// request is clamped to the nearest attainable one ([`Capability::clamp`]) and the
    /// result says so. Invalid input (NaN, α outside the range) gives the pretension
    /// pressures of the neutral pose, flagged.
    pub fn inverse(
        &self,
        muscle: &MuscleCoeffs<R>,
        alpha_rad: R,
        torque_nm: R,
        stiffness_nm_per_rad: R,
    ) -> InverseSolution<R> {
        if !self.alpha_in_range(alpha_rad) {
            return self.safe_pretension(muscle, Limited::INVALID_INPUT);
        }
        let pose = self.pose(muscle, alpha_rad);
        let cap = pose.capability(self);
        self.solve_within(&pose, &cap, torque_nm, stiffness_nm_per_rad)
    }

    /// The joint angle is a number inside the joint's range: the inverse model's and the
    /// evaluation's precondition.
    #[inline]
    pub fn alpha_in_range(&self, alpha_rad: R) -> bool {
        alpha_rad.is_finite() && alpha_rad >= self.alpha_min_rad && alpha_rad <= self.alpha_max_rad
    }

    /// The inverse model on an already evaluated pose and its capability (lets a caller
    /// that also reports the capability evaluate the muscles once).
    pub fn solve_within(
        &self,
        pose: &JointPose<R>,
        cap: &Capability<R>,
        torque_nm: R,
        stiffness_nm_per_rad: R,
    ) -> InverseSolution<R> {
        let (t, k, mut limited) = cap.clamp(torque_nm, stiffness_nm_per_rad);
        if !(torque_nm.is_finite() && stiffness_nm_per_rad.is_finite()) {
            limited = limited.with(Limited::INVALID_INPUT);
        }
        let Some(p) = pose.pressures_for(t, k) else {
            return self.safe_pretension_at(pose, limited.with(Limited::SINGULAR));
        };
        let (lo, hi) = (self.pressure_min_bar, self.pressure_max_bar);
        let tol = R::from_f64(1e-3);
        let pc = [p[0].clamp_to(lo, hi), p[1].clamp_to(lo, hi)];
        if (pc[0] - p[0]).abs() > tol || (pc[1] - p[1]).abs() > tol {
            limited = limited.with(Limited::PRESSURE);
        }
        InverseSolution {
            pressure_bar: pc,
            torque_nm: pose.torque_nm(pc),
            stiffness_nm_per_rad: pose.stiffness_nm_per_rad(pc),
            limited,
        }
    }

    fn safe_pretension_at(&self, pose: &JointPose<R>, limited: Limited) -> InverseSolution<R> {
        let p = self.pretension_pressure_bar(pose);
        InverseSolution {
            pressure_bar: p,
            torque_nm: pose.torque_nm(p),
            stiffness_nm_per_rad: pose.stiffness_nm_per_rad(p),
            limited,
        }
    }

    /// Pressures that put both cables at the anti-slack force at this pose.
    pub fn pretension_pressure_bar(&self, pose: &JointPose<R>) -> [R; 2] {
        let f = self.anti_slack_force_n;
        let (lo, hi) = (self.pressure_min_bar, self.pressure_max_bar);
        [
            pose.muscles[0].pressure_for_force_bar(f).clamp_to(lo, hi),
            pose.muscles[1].pressure_for_force_bar(f).clamp_to(lo, hi),
        ]
    }

    /// The pretension pressures at the neutral pose: the state the rig is calibrated in.
    fn safe_pretension(&self, muscle: &MuscleCoeffs<R>, limited: Limited) -> InverseSolution<R> {
        let pose = self.pose(muscle, R::ZERO);
        self.safe_pretension_at(&pose, limited)
    }

    /// The torque every pose of the range can deliver in both directions (§3.2: "a range of
    /// torque that is achievable for the whole joint space"), scanning the range in
    /// `steps` equal intervals (the thesis uses 1° steps).
    pub fn whole_range_torque_nm(&self, muscle: &MuscleCoeffs<R>, steps: u32) -> (R, R) {
        let mut lo = R::from_f64(-1e30);
        let mut hi = R::from_f64(1e30);
        let n = steps.max(1);
        for i in 0..=n {
            let a = self.alpha_min_rad
                + (self.alpha_max_rad - self.alpha_min_rad) * R::from_f64(i as f64 / n as f64);
            let cap = self.pose(muscle, a).capability(self);
            let (t_lo, t_hi) = cap.torque_limits_nm();
            lo = lo.max(t_lo);
            hi = hi.min(t_hi);
        }
        (lo, hi)
    }
}
