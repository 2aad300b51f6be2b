//! The load cell's amplifier filter: the force is measured through a low-pass, which lags
//! it behind the encoders by a group delay that depends on the frequency, and damps the
//! fast part of it. A dead time shifts every frequency alike and damps none, so a rig with
//! an anti-alias filter of a few hertz is not a dead time of any length.

use super::fitted_and_shape;
use super::DynCtx;
use super::DynTerm;
use super::Experiment;
use super::Family;
use super::ModelEffect;
use super::Shape;
use super::ShapeParam;
use pam_numerics::filter::Butterworth;
use pam_numerics::lsq::Column;
use std::collections::HashMap;
use std::f64::consts::PI;
use std::sync::Arc;

/// The corners tried, Hz: a group delay of 150 ms (the longest dead time tried) down to
/// 13 ms, just above the rig's own lag (`Settings::converter_lag_s`), half an octave apart
/// (measured on 300 dynamic logs of the three generators: a third of an octave named no
/// more of them right, and took longer).
const CORNERS_HZ: [f64; 8] = [1.5, 2.1, 3.0, 4.2, 6.0, 8.5, 12.0, 17.0];

/// The filter's order: an amplifier's anti-alias filter is most often a second-order
/// Butterworth (a Sallen–Key stage).
const ORDER: usize = 2;

/// A low-pass of the measured force: a second-order Butterworth whose corner is on a grid.
pub struct LoadCellFilter;
impl ModelEffect for LoadCellFilter {
    fn id(&self) -> &'static str {
        "load_cell_filter"
    }
    fn family(&self) -> Option<Family> {
        Some(Family::Delay)
    }
    fn shape_name(&self) -> &'static str {
        "sensor_lowpass"
    }
    fn summary(&self) -> &'static str {
        "the load cell's amplifier filters the force (a second-order low-pass): it lags the motion and its fast part is damped"
    }
    fn signature(&self) -> &'static str {
        "the residual lags the inputs by more at the motion's faster frequencies, and the measured force is smaller there than the model's"
    }
    fn applies(&self, e: Experiment) -> bool {
        // a step trial's base is fitted to the measured force end to end (its second order
        // takes a filter's lag and damping in): only a dynamic trial's model is of the
        // force as it acts
        e == Experiment::Dynamic
    }
    fn shapes(&self, ctx: &DynCtx) -> Vec<Shape> {
        let nyquist_hz = 0.5 / ctx.p.dt_s;
        CORNERS_HZ
            .iter()
            // a corner near Nyquist is no filter the samples can show
            .filter(|&&hz| hz < 0.5 * nyquist_hz)
            .map(|&hz| Shape(vec![(ShapeParam::CornerHz, hz)]))
            .collect()
    }
    fn dynamic_term(&self, _ctx: &DynCtx, shape: &Shape) -> DynTerm {
        DynTerm {
            force_lowpass_hz: shape.get(ShapeParam::CornerHz).unwrap_or(0.0),
            ..Default::default()
        }
    }
    fn report_params(
        &self,
        _ctx: &DynCtx,
        fitted: &[(String, f64)],
        shape: &Shape,
    ) -> Vec<(String, f64)> {
        let mut v = fitted_and_shape(fitted, shape);
        if let Some(hz) = shape.get(ShapeParam::CornerHz) {
            v.push(("group_delay_s".to_string(), group_delay_s(hz)));
        }
        v
    }
}

/// The low-frequency group delay of the second-order Butterworth of corner `hz`: 2ζ/ω with
/// ζ = 1/√2.
pub fn group_delay_s(hz: f64) -> f64 {
    std::f64::consts::SQRT_2 / (2.0 * PI * hz)
}

/// Columns through the force's low-pass, each source column filtered once per corner: the
/// shapes' fits with every base variant share the base's columns, and with them the
/// products of the Gram matrix ([`pam_numerics::lsq::GramMemo`] keys on the columns'
/// storage). Holds each source column, so that its address is not reused while its
/// filtered copy is served.
#[derive(Default)]
pub struct LowpassMemo {
    filtered: HashMap<SourceAtCorner, SourceAndFiltered>,
}

/// A source column's storage address and a corner's bits.
type SourceAtCorner = (usize, u64);
/// The source column (held, so that its address stays its own) and its filtered copy.
type SourceAndFiltered = (Arc<Vec<f64>>, Arc<Vec<f64>>);

impl LowpassMemo {
    /// Column `c` through the low-pass of corner `hz` (started in its steady state);
    /// `None` when the corner is not below the samples' Nyquist frequency.
    pub fn column(&mut self, c: &Column, hz: f64, dt_s: f64) -> Option<Column> {
        let filter = Butterworth::lowpass(ORDER, hz, 1.0 / dt_s).ok()?;
        let mut through = |v: &Arc<Vec<f64>>| {
            let key = (Arc::as_ptr(v) as usize, hz.to_bits());
            let (_, out) = self.filtered.entry(key).or_insert_with(|| {
                let mut out = v.to_vec();
                filter.filter_in_place(&mut out);
                (v.clone(), Arc::new(out))
            });
            out.clone()
        };
        let axis = [
            c.axis[0].as_ref().map(&mut through),
            c.axis[1].as_ref().map(&mut through),
        ];
        Some(Column {
            name: c.name.clone(),
            axis,
        })
    }

    /// Keeps the columns filtered at the corners `hz` only.
    pub fn retain_corners(&mut self, hz: &[f64]) {
        self.filtered
            .retain(|&(_, bits), _| hz.iter().any(|h| h.to_bits() == bits));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_column_through_the_filter_keeps_its_level_and_lags_a_slow_sine() {
        let dt_s = 0.005;
        let hz = 3.0;
        let n = 4000;
        let f_in = 0.5;
        let x: Vec<f64> = (0..n)
            .map(|i| 2.0 + (2.0 * PI * f_in * i as f64 * dt_s).sin())
            .collect();
        let c = Column::both("c", x.clone(), x);
        let mut memo = LowpassMemo::default();
        let out = memo.column(&c, hz, dt_s).expect("below Nyquist");
        let y = out.axis[0].as_ref().expect("x axis");
        // steady state at the first sample: no start-up step
        assert!((y[0] - 2.0).abs() < 1e-9);
        // the sine's lag, the shift that matches it best, is the group delay
        let tau = group_delay_s(hz);
        let err = |k: usize| -> f64 {
            (1000..3000)
                .map(|i| {
                    let s = 2.0 + (2.0 * PI * f_in * (i - k) as f64 * dt_s).sin();
                    (y[i] - s).powi(2)
                })
                .sum()
        };
        let lag_samples = (0..60)
            .min_by(|&a, &b| err(a).total_cmp(&err(b)))
            .expect("shifts");
        let lag_s = lag_samples as f64 * dt_s;
        assert!(
            (lag_s - tau).abs() <= 0.006,
            "lag {lag_s} s against a group delay of {tau} s"
        );
        let again = memo.column(&c, hz, dt_s).expect("below Nyquist");
        assert!(Arc::ptr_eq(
            again.axis[0].as_ref().expect("x"),
            out.axis[0].as_ref().expect("x")
        ));
        let short = Column::both("c", vec![0.0; 8], vec![0.0; 8]);
        assert!(memo.column(&short, 150.0, dt_s).is_none());
    }
}
