//! `pamctl commission --apply`: the fixes a configuration record can take, written to the
//! device and persisted in its flash, for the next run to check.

use super::analysis::{ConfigFix, Finding};
use anyhow::{anyhow, bail};
use pam_link::Client;
use pam_protocol::{Config, ConfigSection, ReplyData, RequestBody};

/// Writes every finding's fix to the device's calibration and persists it; refuses when a
/// finding has no such fix (a cable or a tube to change by hand). What it changed, in words.
pub fn apply(client: &Client, findings: &[Finding]) -> anyhow::Result<Vec<String>> {
    let fixes: Vec<ConfigFix> = findings.iter().filter_map(|f| f.fix).collect();
    if fixes.len() != findings.len() || fixes.is_empty() {
        bail!("--apply: a finding needs a change at the rig, not in the configuration: make it by hand");
    }
    let mut cal = match client.request(RequestBody::GetConfig(ConfigSection::Calibration))? {
        ReplyData::Config(Config::Calibration(c)) => c,
        other => {
            return Err(anyhow!(
                "the device answered the calibration request with {other:?}"
            ))
        }
    };
    let mut done = Vec::new();
    for fix in fixes {
        match fix {
            ConfigFix::EncoderSign(j) => {
                cal.encoder[j].sign = -cal.encoder[j].sign;
                done.push(format!("encoder {} sign = {}", j + 1, cal.encoder[j].sign));
            }
            ConfigFix::EncoderScale(j, ratio) => {
                let counts = (f64::from(cal.encoder[j].counts_per_rev) * ratio).round();
                cal.encoder[j].counts_per_rev = counts as u32;
                done.push(format!("encoder {} counts_per_rev = {counts}", j + 1));
            }
            ConfigFix::LoadCellGain(axis, g) => {
                cal.load_cell.gain_n_per_v[axis] /= g as f32;
                done.push(format!(
                    "load_cell gain_n_per_v[{axis}] = {:.4}",
                    cal.load_cell.gain_n_per_v[axis]
                ));
            }
        }
    }
    client.command(RequestBody::SetConfig(Config::Calibration(cal)))?;
    client.command(RequestBody::PersistConfig)?;
    Ok(done)
}
