//! The telemetry as a live stream for PlotJuggler: one UDP datagram per sent sample, each
//! one JSON object, as PlotJuggler's "UDP Server" source reads it with its JSON parser.
//!
//! PlotJuggler's JSON parser takes the time from a top-level number named `timestamp`
//! (seconds) when "use field as timestamp if available" is ticked, and flattens nested
//! objects into series named by their path (`/alpha_deg/j1`); strings and nulls are
//! skipped, so every field here is a number. Its UDP server reads at most 2048 bytes per
//! datagram: a message is a few hundred.
//!
//! The stream is decimated on the device's clock (`--plotjuggler-hz`, 200 Hz by default:
//! a person cannot see more, and PlotJuggler redraws at a few tens of Hz). The timestamp is
//! the host's Unix time at the first sample plus the device's elapsed time, so samples
//! are spaced by the device's clock and a second `watch` or `record` continues the same
//! time axis instead of starting again at 0.
//!
//! Sending never blocks and never fails the command: PlotJuggler may be closed, and the
//! recording or the live view matters more than the plot. Failed sends are counted.

use crate::cmd::record::{mode_code, state_code, Clock};
use anyhow::Context;
use clap::Args;
use pam_protocol::Telemetry;
use serde_json::{json, Map, Value};
use std::net::{SocketAddr, ToSocketAddrs, UdpSocket};
use std::time::{SystemTime, UNIX_EPOCH};

/// PlotJuggler's UDP datagram buffer (its UDP server's `recvfrom` length).
pub const MAX_DATAGRAM_BYTES: usize = 2048;

/// The stream options shared by `watch` and `record`.
#[derive(Args, Debug, Clone, Default)]
pub struct PlotJugglerArgs {
    /// Also stream the telemetry to PlotJuggler's UDP Server (JSON) at HOST:PORT, e.g.
    /// 127.0.0.1:9870 (docs/bring-up.md, live plots).
    #[arg(long, value_name = "HOST:PORT")]
    pub plotjuggler: Option<String>,
    /// Samples per second sent to PlotJuggler (decimated on the device's clock).
    #[arg(long, default_value_t = 200.0, value_name = "HZ")]
    pub plotjuggler_hz: f64,
}

impl PlotJugglerArgs {
    /// The sink when `--plotjuggler` is given.
    pub fn open(&self) -> anyhow::Result<Option<Sink>> {
        match &self.plotjuggler {
            None => Ok(None),
            Some(addr) => Sink::open(addr, self.plotjuggler_hz).map(Some),
        }
    }
}

/// A decimating UDP JSON sender.
pub struct Sink {
    socket: UdpSocket,
    target: SocketAddr,
    period_s: f64,
    clock: Clock,
    /// Host Unix time of the first sample, s.
    epoch_s: Option<f64>,
    /// Device time at which the next sample is due, s.
    next_due_s: f64,
    pub sent: u64,
    pub send_errors: u64,
}

impl Sink {
    pub fn open(addr: &str, rate_hz: f64) -> anyhow::Result<Sink> {
        if !(rate_hz.is_finite() && rate_hz > 0.0 && rate_hz <= 10_000.0) {
            anyhow::bail!("--plotjuggler-hz {rate_hz}: give a rate in (0, 10000] Hz");
        }
        let target = addr
            .to_socket_addrs()
            .with_context(|| format!("--plotjuggler {addr}: not a HOST:PORT address"))?
            .next()
            .with_context(|| format!("--plotjuggler {addr}: the name resolves to nothing"))?;
        let local = if target.is_ipv4() {
            "0.0.0.0:0"
        } else {
            "[::]:0"
        };
        let socket = UdpSocket::bind(local).context("cannot open a UDP socket")?;
        socket
            .set_nonblocking(true)
            .context("cannot make the UDP socket non-blocking")?;
        Ok(Sink {
            socket,
            target,
            period_s: 1.0 / rate_hz,
            clock: Clock::default(),
            epoch_s: None,
            next_due_s: 0.0,
            sent: 0,
            send_errors: 0,
        })
    }

    /// Sends `t` if it is due; true when a datagram left.
    pub fn offer(&mut self, t: &Telemetry) -> bool {
        let t_s = self.clock.seconds(t.time_us);
        let epoch_s = *self.epoch_s.get_or_insert_with(unix_now_s);
        // half a telemetry period of slack: 1 kHz telemetry at 200 Hz is every 5th sample
        if t_s + 1e-6 < self.next_due_s {
            return false;
        }
        self.next_due_s += self.period_s;
        if self.next_due_s <= t_s {
            // a gap in the telemetry: start again from this sample
            self.next_due_s = t_s + self.period_s;
        }
        let bytes = message(t, epoch_s + t_s).to_string();
        match self.socket.send_to(bytes.as_bytes(), self.target) {
            Ok(_) => {
                self.sent += 1;
                true
            }
            Err(_) => {
                self.send_errors += 1;
                false
            }
        }
    }
}

fn unix_now_s() -> f64 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map(|d| d.as_secs_f64())
        .unwrap_or(0.0)
}

/// A number for JSON, with the f32's shortest decimal form (0.1, not 0.10000000149011612);
/// a non-finite value (never sent by a sane device) is 0, as in the log.
fn num(x: f32) -> Value {
    let x: f64 = if x.is_finite() {
        x.to_string().parse().unwrap_or(0.0)
    } else {
        0.0
    };
    json!(x)
}

fn channels(prefix: &str, v: [f32; 4]) -> Value {
    let mut m = Map::new();
    for (i, x) in v.into_iter().enumerate() {
        m.insert(format!("{prefix}{}", i + 1), num(x));
    }
    Value::Object(m)
}

/// One datagram's JSON object; `timestamp_s` is PlotJuggler's time axis.
pub fn message(t: &Telemetry, timestamp_s: f64) -> Value {
    let mut m = json!({
        "timestamp": timestamp_s,
        "alpha_deg": {
            "j1": num(t.alpha_rad[0].to_degrees()),
            "j2": num(t.alpha_rad[1].to_degrees()),
        },
        "force_n": { "x": num(t.force_user_n[0]), "y": num(t.force_user_n[1]) },
        "pressure_bar": channels("ch", t.pressure_cmd_bar),
        "current_ma": channels("ch", t.current_ma),
        "state": state_code(t.state.into()),
        "mode": mode_code(t.mode),
        "faults": t.faults,
        "limited": t.limited,
        "loop_us": { "exec": t.loop_exec_us, "jitter": t.loop_jitter_us },
        "seq": t.seq,
    });
    if let Some(f) = t.force_ref_n {
        m["force_ref_n"] = json!({ "x": num(f[0]), "y": num(f[1]) });
    }
    m
}

#[cfg(test)]
mod tests {
    use super::{message, Sink, MAX_DATAGRAM_BYTES};
    use pam_control::State;
    use pam_protocol::{ModeKind, Telemetry};
    use std::net::UdpSocket;
    use std::time::Duration;

    fn sample(seq: u32) -> Telemetry {
        Telemetry {
            seq,
            time_us: seq * 1000,
            alpha_rad: [0.5f32.to_radians() * seq as f32, -0.1],
            force_user_n: [1.5, f32::NAN],
            force_ref_n: Some([10.0, 0.0]),
            current_ma: [4.0, 5.0, 6.0, 7.0],
            pressure_cmd_bar: [0.1, 0.5, 1.0, 1.5],
            mode: ModeKind::ForceClosedLoop,
            state: State::Armed.into(),
            faults: 0x12,
            limited: 3,
            loop_exec_us: 12,
            loop_jitter_us: 7,
        }
    }

    #[test]
    fn message_has_numeric_fields_in_plotjuggler_form() {
        let m = message(&sample(4), 1000.25);
        assert_eq!(m["timestamp"], 1000.25);
        assert!((m["alpha_deg"]["j1"].as_f64().unwrap() - 2.0).abs() < 1e-5);
        assert_eq!(m["force_n"]["x"], 1.5);
        assert_eq!(m["force_n"]["y"], 0.0, "a NaN is sent as 0, not null");
        assert_eq!(m["pressure_bar"]["ch4"], 1.5);
        assert_eq!(m["pressure_bar"]["ch1"], 0.1, "the f32's shortest form");
        assert_eq!(m["current_ma"]["ch1"], 4.0);
        assert_eq!(m["force_ref_n"]["x"], 10.0);
        assert_eq!(
            (m["state"].as_f64(), m["mode"].as_f64()),
            (Some(1.0), Some(5.0))
        );
        assert_eq!(m["faults"], 0x12);
        assert!(m.to_string().len() < MAX_DATAGRAM_BYTES);
    }

    #[test]
    fn sink_decimates_on_the_device_clock() {
        let rx = UdpSocket::bind("127.0.0.1:0").unwrap();
        rx.set_read_timeout(Some(Duration::from_secs(1))).unwrap();
        let addr = rx.local_addr().unwrap().to_string();
        let mut sink = Sink::open(&addr, 200.0).unwrap();
        // one second of 1 kHz telemetry, each datagram read as it leaves (a burst of
        // hundreds would overflow the receiver's buffer, which the real-time stream never does)
        let mut buf = [0u8; 4096];
        let mut last = f64::NEG_INFINITY;
        let mut sent = 0;
        for s in 0..1000 {
            if sink.offer(&sample(s)) {
                sent += 1;
                let n = rx.recv(&mut buf).unwrap();
                let v: serde_json::Value = serde_json::from_slice(&buf[..n]).unwrap();
                let ts = v["timestamp"].as_f64().unwrap();
                assert!(ts > last);
                last = ts;
                assert_eq!(v["seq"].as_u64(), Some(s as u64 / 5 * 5));
            }
        }
        assert_eq!(sent, 200);
        assert_eq!(sink.sent, 200);
    }

    #[test]
    fn bad_rate_and_address_are_refused() {
        assert!(Sink::open("127.0.0.1:9870", 0.0).is_err());
        assert!(Sink::open("not an address", 200.0).is_err());
    }
}
