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
            ConfigFix::EncoderZero(j, error_rad) => {
                cal.encoder[j].zero_rad += error_rad as f32;
                done.push(format!(
                    "encoder {} zero_rad = {:.4}",
                    j + 1,
                    cal.encoder[j].zero_rad
                ));
            }
            ConfigFix::ChannelMap(drives) => {
                cal.output_of_channel = compose(cal.output_of_channel, drives);
                done.push(format!("output_of_channel = {:?}", cal.output_of_channel));
            }
        }
    }
    client.command(RequestBody::SetConfig(Config::Calibration(cal)))?;
    client.command(RequestBody::PersistConfig)?;
    Ok(done)
}

/// The stored map after the steps found that channel k, sent through `stored`, drives the
/// converter of channel `drives[k]`: that converter's stage is the one channel k used.
pub fn compose(stored: [u8; 4], drives: [u8; 4]) -> [u8; 4] {
    let mut map = stored;
    for k in 0..4 {
        map[(drives[k] & 3) as usize] = stored[k];
    }
    map
}

#[cfg(test)]
mod tests {
    use super::compose;

    #[test]
    fn the_measured_exchange_is_composed_with_the_stored_map() {
        // channels 1 and 3 exchanged at the identity: stage 3 drives channel 1's converter
        assert_eq!(compose([0, 1, 2, 3], [2, 1, 0, 3]), [2, 1, 0, 3]);
        // measured again through that map, the rig is as stored
        assert_eq!(compose([2, 1, 0, 3], [0, 1, 2, 3]), [2, 1, 0, 3]);
        // a second exchange on top of a stored one
        assert_eq!(compose([2, 1, 0, 3], [0, 3, 2, 1]), [2, 3, 0, 1]);
    }
}
