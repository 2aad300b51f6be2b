//! The real-time loop: requests in, one device period, the plant over the same period,
//! replies and telemetry out, sleeping to absolute deadlines.

use crate::conn::{push_frame, Connection, Event};
use crate::plant::Plant;
use crate::LoopStats;
use pam_protocol::{DeviceMessage, FrameDecoder};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{Receiver, TryRecvError, TrySendError};
use std::time::{Duration, Instant};

/// Further behind than this (machine suspended, debugger) the loop resynchronises instead
/// of bursting through the backlog.
const MAX_CATCH_UP: Duration = Duration::from_secs(1);
pub(crate) fn real_time_loop(
    mut plant: Plant,
    events: Receiver<Event>,
    stop: &AtomicBool,
    stats: &LoopStats,
) {
    let mut conns: Vec<Connection> = Vec::new();
    // the newest connection that has sent anything gets the telemetry
    let mut streaming: Option<u64> = None;
    let start = Instant::now();
    let mut deadline = start;
    let mut device_time_us: u64 = 0;
    let mut last_exec_us: u16 = 0;
    let mut replies: Vec<(u64, Vec<u8>)> = Vec::new();
    while !stop.load(Ordering::Relaxed) {
        let period_us = plant.device.period_us().max(1) as u64;
        let period = Duration::from_micros(period_us);
        let now = Instant::now();
        if now < deadline {
            std::thread::sleep(deadline - now);
        }
        let began = Instant::now();
        let mut behind = began.saturating_duration_since(deadline);
        if behind > MAX_CATCH_UP {
            stats.resyncs.fetch_add(1, Ordering::Relaxed);
            deadline = began;
            behind = Duration::ZERO;
        }
        if behind >= period {
            stats.late.fetch_add(1, Ordering::Relaxed);
        }
        let jitter_us = behind.as_micros().min(u16::MAX as u128) as u16;
        stats
            .max_jitter_us
            .fetch_max(jitter_us as u64, Ordering::Relaxed);

        // 1. requests
        loop {
            match events.try_recv() {
                Ok(Event::Opened { conn, out }) => conns.push(Connection {
                    id: conn,
                    out,
                    decoder: FrameDecoder::new(),
                }),
                Ok(Event::Closed { conn }) => {
                    conns.retain(|c| c.id != conn);
                    if streaming == Some(conn) {
                        streaming = None;
                    }
                }
                Ok(Event::Bytes { conn, bytes }) => {
                    let Some(c) = conns.iter_mut().find(|c| c.id == conn) else {
                        continue;
                    };
                    if streaming.is_none_or(|s| s < conn) {
                        streaming = Some(conn);
                    }
                    let mut out = Vec::new();
                    for b in bytes {
                        if let Some(frame) = c.decoder.push(b) {
                            let reply = plant.handle_frame(frame);
                            push_frame(&mut out, &DeviceMessage::Reply(reply));
                        }
                    }
                    if !out.is_empty() {
                        replies.push((conn, out));
                    }
                }
                Ok(Event::Inject(injection)) => plant.inject(injection, device_time_us),
                Err(TryRecvError::Empty) => break,
                Err(TryRecvError::Disconnected) => return,
            }
        }

        // 2. the device's control period (inside the emulated board), then the plant over
        // the same period; an injected stall is slept: a real overrun
        let result = plant.period(
            period_us as u32,
            device_time_us,
            last_exec_us,
            jitter_us,
            |stall_us| std::thread::sleep(Duration::from_micros(stall_us as u64)),
        );
        device_time_us += period_us;

        // 3. output
        let mut stream = Vec::new();
        if let Some(e) = result.fault_event {
            push_frame(&mut stream, &DeviceMessage::FaultEvent(e));
        }
        if let Some(t) = result.telemetry {
            push_frame(&mut stream, &DeviceMessage::Telemetry(t));
        }
        if let Some(s) = streaming {
            if !stream.is_empty() {
                replies.push((s, stream));
            }
        }
        for (conn, bytes) in replies.drain(..) {
            let Some(c) = conns.iter().find(|c| c.id == conn) else {
                continue;
            };
            let n = bytes.len() as u64;
            match c.out.try_send(bytes) {
                Ok(()) => {
                    stats.bytes_sent.fetch_add(n, Ordering::Relaxed);
                }
                Err(TrySendError::Full(_)) => {
                    stats.frames_dropped.fetch_add(1, Ordering::Relaxed);
                }
                Err(TrySendError::Disconnected(_)) => {}
            }
        }

        let exec_us = began.elapsed().as_micros().min(u16::MAX as u128) as u16;
        last_exec_us = exec_us;
        stats
            .exec_us_total
            .fetch_add(exec_us as u64, Ordering::Relaxed);
        stats
            .max_exec_us
            .fetch_max(exec_us as u64, Ordering::Relaxed);
        stats.periods.fetch_add(1, Ordering::Relaxed);
        deadline += period;
    }
}
