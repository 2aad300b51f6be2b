//! Arithmetic of the firmware's drivers, kept apart from the registers so that it is
//! tested on the host: the firmware (`firmware/`, thumbv7em only) wraps each piece around
//! its peripheral. `no_std`, no heap, no panic path, f32.
#![cfg_attr(not(test), no_std)]
#![forbid(unsafe_code)]

pub mod adc_scale;
pub mod board_checks;
pub mod board_revision;
pub mod counter;
pub mod current_loop;
pub mod cycle_stats;
pub mod debounce;
pub mod nmi;
pub mod stack_guard;
pub mod vdda;
