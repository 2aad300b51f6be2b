//! How a hidden effect is handed to the driver: either an additive term scaled by a
//! strength λ, or a function of λ giving the whole noise-free force. The driver picks λ
//! so that the effect has its target relative size.

use crate::signal::Forces;

/// The effect's force as a function of its strength λ (a physical parameter: N, s, rad…).
pub enum Form<'a> {
    /// Logged force = base + λ · unit (on the fine grid).
    Additive(Forces),
    /// Logged force (noise-free, fine grid) at strength λ.
    Whole(Box<dyn Fn(f64) -> Forces + Sync + 'a>),
}

/// One effect ready to be scaled.
pub struct EffectModel<'a> {
    pub form: Form<'a>,
    /// Range searched for λ; the size is assumed to grow with λ.
    pub lambda_range: (f64, f64),
    /// The physical parameters at strength λ.
    pub params: Box<dyn Fn(f64) -> Vec<(String, f64)> + Sync + 'a>,
}

impl<'a> EffectModel<'a> {
    pub fn additive(
        unit: Forces,
        lambda_range: (f64, f64),
        params: impl Fn(f64) -> Vec<(String, f64)> + Sync + 'a,
    ) -> Self {
        EffectModel {
            form: Form::Additive(unit),
            lambda_range,
            params: Box::new(params),
        }
    }

    pub fn whole(
        apply: impl Fn(f64) -> Forces + Sync + 'a,
        lambda_range: (f64, f64),
        params: impl Fn(f64) -> Vec<(String, f64)> + Sync + 'a,
    ) -> Self {
        EffectModel {
            form: Form::Whole(Box::new(apply)),
            lambda_range,
            params: Box::new(params),
        }
    }
}

/// Named parameters from pairs.
pub fn named(pairs: &[(&str, f64)]) -> Vec<(String, f64)> {
    pairs.iter().map(|(k, v)| (k.to_string(), *v)).collect()
}
