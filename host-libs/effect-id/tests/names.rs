//! The names are the JSON's words: serde, `Display` and `FromStr` agree on them, and the
//! id ↔ family table goes both ways.

use pam_effect_id::{EffectId, Family};

#[test]
fn serde_display_and_from_str_agree() {
    for e in EffectId::ALL {
        let json = serde_json::to_string(&e).unwrap();
        assert_eq!(json, format!("\"{e}\""));
        assert_eq!(serde_json::from_str::<EffectId>(&json).unwrap(), e);
        assert_eq!(e.name().parse::<EffectId>().unwrap(), e);
    }
    for f in Family::ALL {
        let json = serde_json::to_string(&f).unwrap();
        assert_eq!(json, format!("\"{f}\""));
        assert_eq!(serde_json::from_str::<Family>(&json).unwrap(), f);
        assert_eq!(f.name().parse::<Family>().unwrap(), f);
    }
}

#[test]
fn every_family_has_its_id_and_back() {
    for f in Family::ALL {
        assert_eq!(f.catalog_id().family(), Some(f));
    }
    assert_eq!(EffectId::MainsHum.family(), None);
    assert_eq!(EffectId::CableSlip.family(), Some(Family::Backlash));
    assert_eq!(
        Family::Friction.catalog_id().name(),
        "carrier_ball_friction"
    );
}

#[test]
fn an_unknown_name_lists_the_valid_ones() {
    let e = "coulomb".parse::<EffectId>().unwrap_err().to_string();
    assert!(e.contains("unknown effect `coulomb`"), "{e}");
    for id in EffectId::ALL {
        assert!(e.contains(id.name()), "{e}");
    }
    let f = "frition".parse::<Family>().unwrap_err().to_string();
    assert!(
        f.contains("unknown family `frition`") && f.contains("rate_limits"),
        "{f}"
    );
}
