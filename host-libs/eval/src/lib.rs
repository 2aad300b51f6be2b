//! `pam-eval`: how well the model loop does, measured.
//!
//! - [`cases`]: the logs of the cross-generator runs, each with its truth, its footprint and
//!   the same trial at the other stiffness level where the generator can run it.
//! - [`footprint`]: how much of a log a hidden effect is (with it and without it, one seed).
//! - [`judge`]: scores a diagnosis (its JSON) against the truth a generator hid in the log,
//!   and draws the confusion matrix of many cases.
//! - [`pairs`]: pairs of logs at two stiffness levels, friction or hysteresis, decided.
//! - [`strict`]: the final model judged whole (right verdict, right first family, no family
//!   in it that is not in the log), for every generator alike.
//! - `tests/`: the accuracy suites. `cargo test -p pam-eval` runs the fast regression floors
//!   (a few representative cases per family); the full suites (`synth_matrix`, `twin_loop`)
//!   need `--features suites` and run under `cargo xtask eval`.
//! - `examples/`: the research runs whose figures docs/results.md shows (`confusion`,
//!   `impedance_bias`, `impedance_check`); `cargo xtask eval` runs them and writes the page.
//! - `scripts/`: the loop through pamctl on twin logs (`matrix.sh`), the recorded diagnoses
//!   of a fixed set of logs (`behaviour.sh`), and the speed against numpy (`numpy_ratio.sh`).

pub mod cases;
pub mod footprint;
pub mod judge;
pub mod pairs;
pub mod strict;
