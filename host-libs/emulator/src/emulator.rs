//! The running emulator: its real-time thread and the listeners that attach connections.

use crate::conn::{attach, Event};
use crate::inject::Injection;
use crate::plant::Plant;
use crate::rt::real_time_loop;
use crate::{EmulatorError, LoopStats, SimConfig};
use std::io::ErrorKind;
use std::net::TcpListener;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::mpsc::{channel, Receiver, Sender};
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::Duration;

/// A running emulator. Dropping it stops it.
pub struct Emulator {
    events: Sender<Event>,
    stop: Arc<AtomicBool>,
    next_conn: Arc<AtomicU64>,
    pub stats: Arc<LoopStats>,
    threads: Vec<JoinHandle<()>>,
    /// `injected KIND at time_us=N`, one per injection applied.
    injected: Receiver<String>,
}

impl Emulator {
    /// Starts the real-time loop (no connection yet).
    pub fn start(config: SimConfig) -> Result<Emulator, EmulatorError> {
        let (events, rx) = channel();
        let stop = Arc::new(AtomicBool::new(false));
        let stats = Arc::new(LoopStats::default());
        let (reports, injected) = channel();
        let plant = Plant::new(&config, reports)?;
        let rt = {
            let stop = stop.clone();
            let stats = stats.clone();
            std::thread::Builder::new()
                .name("pam-sim-rt".into())
                .spawn(move || real_time_loop(plant, rx, &stop, &stats))
                .map_err(|source| EmulatorError::Thread {
                    thread: "real-time",
                    source,
                })?
        };
        Ok(Emulator {
            events,
            stop,
            next_conn: Arc::new(AtomicU64::new(1)),
            stats,
            threads: vec![rt],
            injected,
        })
    }

    /// Injects a fault at the next period (see [`inject`]).
    pub fn inject(&self, injection: Injection) -> Result<(), EmulatorError> {
        self.events
            .send(Event::Inject(injection))
            .map_err(|_| EmulatorError::Stopped)
    }

    /// Reports of the injections applied since the last call.
    pub fn injected(&self) -> Vec<String> {
        self.injected.try_iter().collect()
    }

    /// Serves TCP on `address` (port 0: any free port); returns the bound address.
    pub fn listen_tcp(&mut self, address: &str) -> Result<std::net::SocketAddr, EmulatorError> {
        let listen = |source| EmulatorError::Listen {
            address: address.to_string(),
            source,
        };
        let listener = TcpListener::bind(address).map_err(listen)?;
        let local = listener.local_addr().map_err(listen)?;
        listener.set_nonblocking(true).map_err(listen)?;
        let (events, stop, next_conn) = (
            self.events.clone(),
            self.stop.clone(),
            self.next_conn.clone(),
        );
        let t = std::thread::Builder::new()
            .name("pam-sim-accept".into())
            .spawn(move || {
                while !stop.load(Ordering::SeqCst) {
                    match listener.accept() {
                        Ok((s, _)) => {
                            s.set_nonblocking(false).ok();
                            s.set_nodelay(true).ok();
                            let Ok(w) = s.try_clone() else { continue };
                            let conn = next_conn.fetch_add(1, Ordering::SeqCst);
                            attach(conn, Box::new(s), Box::new(w), &events, &stop);
                        }
                        Err(e) if e.kind() == ErrorKind::WouldBlock => {
                            std::thread::sleep(Duration::from_millis(20))
                        }
                        Err(_) => std::thread::sleep(Duration::from_millis(20)),
                    }
                }
            })
            .map_err(|source| EmulatorError::Thread {
                thread: "accept",
                source,
            })?;
        self.threads.push(t);
        Ok(local)
    }

    /// Serves the link on a new pseudo-terminal; returns the path clients open
    /// (e.g. `/dev/pts/7`, used as `--device /dev/pts/7`).
    #[cfg(target_os = "linux")]
    pub fn open_pty(&mut self) -> Result<String, EmulatorError> {
        use nix::sys::termios;
        let pty = |what| move |source| EmulatorError::Pty { what, source };
        let pair = nix::pty::openpty(None, None).map_err(pty("open"))?;
        let path = nix::unistd::ttyname(&pair.slave)
            .map_err(pty("name"))?
            .display()
            .to_string();
        // raw: no echo, no line discipline touching the binary frames
        let mut t = termios::tcgetattr(&pair.slave).map_err(pty("configure"))?;
        termios::cfmakeraw(&mut t);
        termios::tcsetattr(&pair.slave, termios::SetArg::TCSANOW, &t).map_err(pty("configure"))?;
        let master = std::fs::File::from(pair.master);
        let writer = master.try_clone().map_err(EmulatorError::PtyIo)?;
        // the emulator keeps the slave open so that the master never sees a hang-up
        // between two clients
        let slave = pair.slave;
        let conn = self.next_conn.fetch_add(1, Ordering::SeqCst);
        attach(
            conn,
            Box::new(master),
            Box::new(writer),
            &self.events,
            &self.stop,
        );
        std::mem::forget(slave);
        Ok(path)
    }

    /// Stops the real-time loop and the listeners.
    pub fn stop(mut self) {
        self.shutdown();
    }

    fn shutdown(&mut self) {
        self.stop.store(true, Ordering::SeqCst);
        for t in self.threads.drain(..) {
            let _ = t.join();
        }
    }
}

impl Drop for Emulator {
    fn drop(&mut self) {
        self.shutdown();
    }
}
