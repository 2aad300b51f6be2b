//! `pamctl config get|set|load|save`: the device's configuration sections as TOML, between
//! a file on the host and the configuration the device runs with (its RAM).
//! `pamctl config persist|restore|erase`: between that RAM copy and the device's flash,
//! from which it boots (a missing record boots the thesis defaults; a damaged one too, with
//! the `SELF_CHECK` fault; `pamctl status` says which).
//!
//! File layout: optional tables `[robot]` (every model parameter), `[calibration]`
//! (encoders, load cell, output stages) and `[limits]` (the supervisor's limits; its
//! `period_s` is the control period). `load` sends each table present; the device checks
//! every value and refuses a section whole.

use crate::LinkArgs;
use anyhow::Context;
use clap::{Subcommand, ValueEnum};
use pam_control::SafetyConfig;
use pam_model::RobotParams;
use pam_protocol::{wire, Calibration, Config, ConfigSection, ReplyData, RequestBody};
use serde::{Deserialize, Serialize};
use std::io::Write;
use std::path::PathBuf;

use pam_link::Client;

#[derive(Subcommand, Debug)]
pub enum ConfigCommand {
    /// Print sections as TOML.
    Get {
        #[arg(value_enum, default_value_t = Section::All)]
        section: Section,
    },
    /// Change values, e.g. `limits.command_timeout_s=0.2 robot.joints.0.pulley_radius_m=0.071`.
    Set {
        #[arg(required = true, value_name = "SECTION.PATH=VALUE")]
        assignments: Vec<String>,
    },
    /// Send the sections found in a TOML file.
    Load { file: PathBuf },
    /// Write every section to a TOML file.
    Save { file: PathBuf },
    /// Make the device write the configuration it runs with to its flash: the next boot
    /// starts from it (not while armed).
    Persist,
    /// Make the device replace the configuration it runs with by the one in its flash
    /// (not while armed; refused, nothing changed, if the flash holds no good record).
    Restore,
    /// Make the device erase the configuration in its flash: the next boot starts from the
    /// thesis defaults. The configuration it runs with now is unchanged.
    Erase,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Section {
    All,
    Robot,
    Calibration,
    Limits,
}

/// The TOML document.
#[derive(Serialize, Deserialize, Debug, Default, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct ConfigFile {
    #[serde(skip_serializing_if = "Option::is_none")]
    pub robot: Option<RobotParams<f32>>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub calibration: Option<Calibration>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub limits: Option<SafetyConfig>,
}

fn get(client: &Client, section: ConfigSection) -> anyhow::Result<Config> {
    match client.request(RequestBody::GetConfig(section))? {
        ReplyData::Config(c) => Ok(c),
        _ => Err(anyhow::anyhow!(
            "the device answered config get with the wrong kind of reply"
        )),
    }
}

pub fn fetch(client: &Client, section: Section) -> anyhow::Result<ConfigFile> {
    let mut f = ConfigFile::default();
    let want = |s: Section| section == Section::All || section == s;
    if want(Section::Robot) {
        if let Config::Robot(p) = get(client, ConfigSection::Robot)? {
            f.robot = Some(p.into());
        }
    }
    if want(Section::Calibration) {
        if let Config::Calibration(c) = get(client, ConfigSection::Calibration)? {
            f.calibration = Some(c);
        }
    }
    if want(Section::Limits) {
        if let Config::Limits(l) = get(client, ConfigSection::Limits)? {
            f.limits = Some(l.into());
        }
    }
    Ok(f)
}

/// f32 values printed in their shortest form (0.32667, not 0.32666999101638794).
fn shortest_floats(v: &mut toml::Value) {
    match v {
        toml::Value::Float(x) if x.is_finite() => {
            *x = (*x as f32).to_string().parse().unwrap_or(*x);
        }
        toml::Value::Array(a) => a.iter_mut().for_each(shortest_floats),
        toml::Value::Table(t) => t.iter_mut().for_each(|(_, v)| shortest_floats(v)),
        _ => {}
    }
}

pub fn to_toml(f: &ConfigFile) -> anyhow::Result<String> {
    let mut v = toml::Value::try_from(f).context("cannot write TOML")?;
    shortest_floats(&mut v);
    toml::to_string_pretty(&v).context("cannot write TOML")
}

pub fn parse_toml(text: &str, source: &str) -> anyhow::Result<ConfigFile> {
    toml::from_str(text).with_context(|| source.to_string())
}

/// Sends every section present; stops at the first refusal (that section is unchanged,
/// the ones before it are applied).
pub fn send(client: &Client, f: &ConfigFile, out: &mut dyn Write) -> anyhow::Result<()> {
    let sections = [
        f.robot.map(|p| ("robot", Config::Robot(p.into()))),
        f.calibration
            .map(|c| ("calibration", Config::Calibration(c))),
        f.limits.map(|l| ("limits", Config::Limits(l.into()))),
    ];
    let mut sent = 0;
    for (name, config) in sections.into_iter().flatten() {
        client
            .command(RequestBody::SetConfig(config))
            .with_context(|| format!("[{name}]"))?;
        writeln!(out, "[{name}] applied")?;
        sent += 1;
    }
    if sent == 0 {
        return Err(anyhow::anyhow!(
            "no [robot], [calibration] or [limits] table to send"
        ));
    }
    Ok(())
}

/// Applies `section.path=value` to a document (path segments are keys or array indices).
pub fn assign(doc: &mut toml::Value, assignment: &str) -> anyhow::Result<()> {
    let (path, value) = assignment.split_once('=').ok_or_else(|| {
        anyhow::anyhow!(
            "`{assignment}`: write SECTION.PATH=VALUE, e.g. limits.command_timeout_s=0.2"
        )
    })?;
    let value: toml::Value = toml::from_str::<toml::Table>(&format!("v = {}", value.trim()))
        .ok()
        .and_then(|mut t| t.remove("v"))
        .ok_or_else(|| {
            anyhow::anyhow!("`{value}` is not a TOML value (number, true/false, [a, b])")
        })?;
    let mut node = &mut *doc;
    let keys: Vec<&str> = path.trim().split('.').collect();
    for (i, key) in keys.iter().enumerate() {
        let next = match node {
            toml::Value::Table(t) => t.get_mut(*key),
            toml::Value::Array(a) => key.parse::<usize>().ok().and_then(|k| a.get_mut(k)),
            _ => None,
        };
        node = next.ok_or_else(|| {
            anyhow::anyhow!(
                "`{path}`: no `{key}` at `{}` (see `pamctl config get` for the names)",
                keys[..i].join(".")
            )
        })?;
    }
    let same_kind = std::mem::discriminant(node) == std::mem::discriminant(&value)
        || matches!(
            (&*node, &value),
            (toml::Value::Float(_), toml::Value::Integer(_))
        );
    if !same_kind {
        return Err(anyhow::anyhow!(
            "`{path}` holds a {}, not a {}",
            node.type_str(),
            value.type_str()
        ));
    }
    *node = match value {
        toml::Value::Integer(i) if node.is_float() => toml::Value::Float(i as f64),
        v => v,
    };
    Ok(())
}

pub fn run(c: ConfigCommand, link: &LinkArgs, out: &mut dyn Write) -> anyhow::Result<()> {
    let client = super::connect(link)?;
    match c {
        ConfigCommand::Get { section } => {
            let text = to_toml(&fetch(&client, section)?)?;
            Ok(write!(out, "{text}")?)
        }
        ConfigCommand::Save { file } => {
            let text = to_toml(&fetch(&client, Section::All)?)?;
            std::fs::write(&file, text)
                .with_context(|| format!("cannot write {}", file.display()))?;
            Ok(writeln!(out, "configuration saved to {}", file.display())?)
        }
        ConfigCommand::Load { file } => {
            let text = std::fs::read_to_string(&file)
                .with_context(|| format!("cannot read {}", file.display()))?;
            let f = parse_toml(&text, &file.display().to_string())?;
            send(&client, &f, out)
        }
        ConfigCommand::Persist => {
            client.command(RequestBody::PersistConfig)?;
            super::done(out, "configuration written to the device's flash")
        }
        ConfigCommand::Restore => {
            client.command(RequestBody::RestoreConfig)?;
            super::done(out, "configuration restored from the device's flash")
        }
        ConfigCommand::Erase => {
            client.command(RequestBody::EraseConfig)?;
            super::done(
                out,
                "configuration in the device's flash erased (the next boot uses the defaults)",
            )
        }
        ConfigCommand::Set { assignments } => {
            let current = fetch(&client, Section::All)?;
            let mut doc = toml::Value::try_from(&current)?;
            let mut touched = Vec::new();
            for a in &assignments {
                assign(&mut doc, a)?;
                touched.push(a.split('.').next().unwrap_or("").trim().to_string());
            }
            let edited: ConfigFile = doc
                .try_into()
                .context("the edited configuration does not read back")?;
            // only the sections that were touched go to the device
            let f = ConfigFile {
                robot: edited
                    .robot
                    .filter(|_| touched.iter().any(|s| s == "robot")),
                calibration: edited
                    .calibration
                    .filter(|_| touched.iter().any(|s| s == "calibration")),
                limits: edited
                    .limits
                    .filter(|_| touched.iter().any(|s| s == "limits")),
            };
            // While armed, the device takes a configuration only from the commander (and
            // only one that tightens the limits): the operator who changes it takes the
            // command, so the client that armed no longer keeps the mode alive.
            if let ReplyData::Status(s) = client.request(RequestBody::GetStatus)? {
                if s.state == wire::State::Armed {
                    client
                        .take_command()
                        .context("taking the command of the armed device")?;
                    writeln!(out, "took the command of the armed device")?;
                }
            }
            send(&client, &f, out)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn thesis_file() -> ConfigFile {
        ConfigFile {
            robot: Some(RobotParams::thesis()),
            calibration: None,
            limits: Some(SafetyConfig::default_1khz()),
        }
    }

    #[test]
    fn toml_round_trips_and_prints_short_floats() {
        let f = thesis_file();
        let text = to_toml(&f).unwrap();
        assert!(text.contains("gain_bar_per_ma = 0.32667"), "{text}");
        assert_eq!(parse_toml(&text, "t").unwrap(), f);
    }

    #[test]
    fn assignments_edit_nested_values_and_explain_mistakes() {
        let mut doc = toml::Value::try_from(thesis_file()).unwrap();
        assign(&mut doc, "limits.command_timeout_s=0.2").unwrap();
        assign(&mut doc, "robot.joints.1.pulley_radius_m = 0.05").unwrap();
        assign(&mut doc, "limits.loadcell_stuck_samples=600").unwrap();
        assign(&mut doc, "limits.slew_bar_per_s=40").unwrap(); // integer into a float
        let f: ConfigFile = doc.clone().try_into().unwrap();
        assert_eq!(f.limits.unwrap().command_timeout_s, 0.2);
        assert_eq!(f.limits.unwrap().slew_bar_per_s, 40.0);
        assert_eq!(f.robot.unwrap().joints[1].pulley_radius_m, 0.05);
        assert!(assign(&mut doc, "limits.nope=1")
            .unwrap_err()
            .to_string()
            .contains("no `nope`"));
        assert!(assign(&mut doc, "limits.command_timeout_s")
            .unwrap_err()
            .to_string()
            .contains("PATH=VALUE"));
        assert!(assign(&mut doc, "limits.command_timeout_s=true")
            .unwrap_err()
            .to_string()
            .contains("float"));
        assert!(assign(&mut doc, "limits.command_timeout_s=abc")
            .unwrap_err()
            .to_string()
            .contains("not a TOML value"));
    }

    #[test]
    fn unknown_tables_and_bad_values_name_the_file_and_line() {
        let e = format!(
            "{:#}",
            parse_toml("[limitz]\nx = 1\n", "cfg.toml").unwrap_err()
        );
        assert!(e.starts_with("cfg.toml:") && e.contains("limitz"), "{e}");
    }
}
