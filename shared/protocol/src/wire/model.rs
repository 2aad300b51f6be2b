//! Wire form of pam-model's robot parameters (`RobotParams<f32>` and its parts), with
//! lossless conversions both ways. Field order here is the wire order; the model's own
//! structs may be reordered freely.

use super::control::same_fields;
use super::schema::wire_struct;
use pam_model::params as d;
use serde::{Deserialize, Serialize};

wire_struct! {
    /// Wire form of [`pam_model::params::MuscleCoeffs`].
    #[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
    pub struct MuscleCoeffs {
        pub pressure_n_per_pa: [f32; 5],
        pub passive_n: [f32; 6],
    }
}

wire_struct! {
    /// Wire form of [`pam_model::params::SegmentMass`].
    #[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
    pub struct SegmentMass {
        pub mass_kg: f32,
        pub com_distance_m: f32,
        pub inertia_com_kg_m2: f32,
    }
}

wire_struct! {
    /// Wire form of [`pam_model::params::JointParams`].
    #[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
    pub struct JointParams {
        pub segment_length_m: f32,
        pub pulley_radius_m: f32,
        pub alpha_min_rad: f32,
        pub alpha_max_rad: f32,
        pub initial_shortening_m: f32,
        pub muscle_rest_length_m: f32,
        pub pretension_pressure_bar: f32,
        pub channel_of_muscle: [u8; 2],
        pub segment: SegmentMass,
    }
}

wire_struct! {
    /// Wire form of [`pam_model::params::IpConverter`].
    #[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
    pub struct IpConverter {
        pub gain_bar_per_ma: f32,
        pub offset_bar: f32,
        pub current_min_ma: f32,
        pub current_max_ma: f32,
        pub output_min_bar: f32,
        pub output_max_bar: f32,
        pub natural_freq_rad_s: f32,
        pub damping_ratio: f32,
    }
}

wire_struct! {
    /// Wire form of [`pam_model::params::LoadCell`].
    #[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
    pub struct LoadCell {
        pub gain_n_per_v: [f32; 2],
        pub offset_v: [f32; 2],
        pub rated_force_n: f32,
    }
}

wire_struct! {
    /// Wire form of [`pam_model::params::GainPlane`].
    #[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
    pub struct GainPlane {
        pub coeffs: [[f32; 3]; 2],
        pub min_gain: f32,
    }
}

wire_struct! {
    /// Wire form of [`pam_model::params::PressureLimits`].
    #[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
    pub struct PressureLimits {
        pub min_bar: f32,
        pub max_bar: f32,
    }
}

wire_struct! {
    /// Wire form of [`pam_model::RobotParams<f32>`].
    #[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
    pub struct RobotParams {
        pub joints: [JointParams; 2],
        pub muscle: MuscleCoeffs,
        pub pressure: PressureLimits,
        pub ip: IpConverter,
        pub load_cell: LoadCell,
        pub gain_plane: GainPlane,
    }
}

/// Both directions of [`same_fields!`].
macro_rules! both_ways {
    ($(#[$a:meta])* $domain:ty, $wire:ty { $($f:ident),* $(,)? $(; map $($m:ident),* $(,)?)? }) => {
        same_fields!($(#[$a])* $domain => $wire { $($f),* $(; map $($m),*)? });
        same_fields!($(#[$a])* $wire => $domain { $($f),* $(; map $($m),*)? });
    };
}

both_ways!(
    d::MuscleCoeffs<f32>,
    MuscleCoeffs {
        pressure_n_per_pa,
        passive_n
    }
);
both_ways!(
    d::SegmentMass<f32>,
    SegmentMass {
        mass_kg,
        com_distance_m,
        inertia_com_kg_m2
    }
);
both_ways!(
    d::IpConverter<f32>,
    IpConverter {
        gain_bar_per_ma,
        offset_bar,
        current_min_ma,
        current_max_ma,
        output_min_bar,
        output_max_bar,
        natural_freq_rad_s,
        damping_ratio,
    }
);
both_ways!(
    d::LoadCell<f32>,
    LoadCell {
        gain_n_per_v,
        offset_v,
        rated_force_n
    }
);
both_ways!(d::GainPlane<f32>, GainPlane { coeffs, min_gain });
both_ways!(d::PressureLimits<f32>, PressureLimits { min_bar, max_bar });
both_ways!(
    d::JointParams<f32>,
    JointParams {
        segment_length_m,
        pulley_radius_m,
        alpha_min_rad,
        alpha_max_rad,
        initial_shortening_m,
        muscle_rest_length_m,
        pretension_pressure_bar,
        channel_of_muscle,
        segment,
    }
);
// one copy each way in the firmware (the handshake's hash, GetConfig and SetConfig share it)
both_ways!(#[inline(never)] pam_model::RobotParams<f32>, RobotParams {
    muscle, pressure, ip, load_cell, gain_plane; map joints
});
