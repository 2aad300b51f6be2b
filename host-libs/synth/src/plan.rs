//! A choice made for every log of a run: one for all, or drawn per seed from a random
//! stream of its own (so a seed's other draws do not change with it).

use rand::Rng;

use crate::error::SynthError;

/// What a [`Plan`] chooses among.
pub trait Choice: Copy + 'static {
    /// Every choice, in the order the draw uses.
    const ALL: &'static [Self];
    /// What the choice is, for an error message.
    const WHAT: &'static str;
    /// The choice's random stream (the draw among them uses `STREAM + 16`).
    const STREAM: u64;
    fn name(self) -> &'static str;
}

/// One choice for every log, or one drawn per seed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Plan<T> {
    Fixed(T),
    /// Uniform over [`Choice::ALL`], from the seed's own stream.
    Random,
}

impl<T: Choice> Plan<T> {
    /// A choice's name, or `random`.
    pub fn parse(s: &str) -> Result<Self, SynthError> {
        if s == "random" {
            return Ok(Plan::Random);
        }
        T::ALL
            .iter()
            .find(|c| c.name() == s)
            .map(|c| Plan::Fixed(*c))
            .ok_or_else(|| {
                let mut choices: Vec<&str> = T::ALL.iter().map(|c| c.name()).collect();
                choices.push("random");
                SynthError::UnknownName {
                    what: T::WHAT,
                    name: s.to_string(),
                    choices: choices.join(", "),
                }
            })
    }

    pub fn for_seed(self, seed: u64) -> T {
        match self {
            Plan::Fixed(c) => c,
            Plan::Random => {
                let mut rng = crate::rng(seed, T::STREAM + 16);
                T::ALL[rng.random_range(0..T::ALL.len())]
            }
        }
    }
}
