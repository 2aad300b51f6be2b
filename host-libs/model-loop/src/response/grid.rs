//! The buffers and grids of the step model's fit.

use super::params::Response;

/// The simulations a fit evaluates into: at the trial gain, and at gain zero (what does not
/// scale with the gain; allocated when needed).
pub(super) struct Sims {
    pub(super) unit: [Vec<f64>; 2],
    pub(super) zero: [Vec<f64>; 2],
}

impl Sims {
    pub(super) fn new(n: usize) -> Self {
        Sims {
            unit: [vec![0.0; n], vec![0.0; n]],
            zero: [Vec::new(), Vec::new()],
        }
    }
}

/// Sorted values read at a fraction of their count (0: the smallest, 1: the largest): the
/// grids' knees.
pub(super) struct Quantiles(pub(super) Vec<f64>);

impl Quantiles {
    pub(super) fn of(mut v: Vec<f64>) -> Self {
        v.sort_by(f64::total_cmp);
        Quantiles(v)
    }
    pub(super) fn at(&self, f: f64) -> f64 {
        self.0[((self.0.len() - 1) as f64 * f) as usize]
    }
}

/// Every start at every (knee, span) of a saturation's grid: spans as fractions of the room
/// between the knee and the top value (at least 0.1 % of the top), the saturation's two
/// parameters written by `set`; knees outermost, then spans, then the starts.
pub(super) fn knee_grid(
    starts: &[Response],
    knees: impl IntoIterator<Item = f64>,
    span_fractions: &[f64],
    top: f64,
    set: impl Fn(&mut Response, f64, f64),
) -> Vec<Response> {
    let mut v = Vec::new();
    for knee in knees {
        for span_f in span_fractions {
            for s in starts {
                let mut r = *s;
                set(
                    &mut r,
                    knee,
                    ((top - knee) * span_f).max(1e-3 * top.max(1e-3)),
                );
                v.push(r);
            }
        }
    }
    v
}
