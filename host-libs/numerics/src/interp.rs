//! Interpolation of sampled series and the evenness of their sampling.

/// An interval may depart from the mean period by this share and the sampling still counts
/// as even (a printed time's rounding is far below).
pub const UNEVEN_SHARE: f64 = 0.01;

/// Whether some interval of `t_s` departs from the mean period `dt_s` by more than
/// [`UNEVEN_SHARE`].
pub fn is_uneven(t_s: &[f64], dt_s: f64) -> bool {
    t_s.windows(2)
        .any(|w| ((w[1] - w[0]) - dt_s).abs() > UNEVEN_SHARE * dt_s)
}

/// `v`, sampled at the increasing times `t`, linearly interpolated at the increasing times
/// `at` (held at the ends).
pub fn linear_at(t: &[f64], v: &[f64], at: &[f64]) -> Vec<f64> {
    let n = t.len().min(v.len());
    if n < 2 {
        return vec![v.first().copied().unwrap_or(0.0); at.len()];
    }
    let mut j = 0;
    at.iter()
        .map(|&x| {
            while j + 2 < n && t[j + 1] < x {
                j += 1;
            }
            let (ta, tb) = (t[j], t[j + 1]);
            let f = ((x - ta) / (tb - ta)).clamp(0.0, 1.0);
            v[j] + f * (v[j + 1] - v[j])
        })
        .collect()
}
