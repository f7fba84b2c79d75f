//! The virtual board on a real Linux network interface: an `AF_PACKET` raw socket bound
//! to EtherType 0x88A4 answers every EtherCAT frame that arrives, so any master on the
//! other side of the wire (SOEM, TwinCAT in a VM, IgH, ethercrab) can drive the board.
//!
//! The board is the (last) slave of the segment: each frame that arrives is processed by
//! the ESC model and sent back out of the same interface, as the ESC's port 0 does when
//! ports 1..3 are closed. Frames the socket itself sent (`PACKET_OUTGOING`) are skipped.
//!
//! Virtual time follows the wall clock here: before each frame, and at least every
//! [`ServeOptions::tick`], the board is stepped towards the time elapsed since the start
//! (by at most one tick each time), so SYNC0, the process-data watchdog and the ADC sampling
//! run at real speed; a board that cannot keep up runs slower and answers every frame all
//! the same.
//!
//! Needs `CAP_NET_RAW` (root). Linux only.

use crate::rig::board::VirtualBoard;
use crate::tools::socketcand::SocketcandServer;
use std::ffi::CString;
use std::io;
use std::os::fd::{AsRawFd, FromRawFd, OwnedFd};
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

/// EtherType of EtherCAT frames.
pub const ETHERTYPE_ECAT: u16 = 0x88A4;

/// A raw `AF_PACKET` socket bound to one interface, receiving EtherCAT frames only.
#[derive(Debug)]
pub struct RawSocket {
    fd: OwnedFd,
    ifindex: i32,
    name: String,
}

/// Why an interface could not be opened.
#[derive(Debug)]
pub enum IfaceError {
    /// No interface of that name (`if_nametoindex` failed).
    NoSuchInterface(String),
    /// The socket call needs `CAP_NET_RAW` (run as root).
    PermissionDenied(String),
    /// Any other I/O error.
    Io(String, io::Error),
}

impl std::fmt::Display for IfaceError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            IfaceError::NoSuchInterface(n) => write!(
                f,
                "unknown network interface `{n}` (see `ip link` for the interfaces of this machine)"
            ),
            IfaceError::PermissionDenied(n) => write!(
                f,
                "no permission to open a raw socket on `{n}`: run as root (needs CAP_NET_RAW)"
            ),
            IfaceError::Io(n, e) => write!(f, "interface `{n}`: {e}"),
        }
    }
}

impl std::error::Error for IfaceError {}

fn last_err() -> io::Error {
    io::Error::last_os_error()
}

impl RawSocket {
    /// Opens a raw socket on `name`, bound to EtherType 0x88A4, in promiscuous mode (so
    /// unicast frames to other addresses arrive too), and brings nothing else up: the
    /// interface must be up (`ip link set NAME up`).
    pub fn open(name: &str) -> Result<Self, IfaceError> {
        let cname =
            CString::new(name).map_err(|_| IfaceError::NoSuchInterface(name.to_string()))?;
        // SAFETY: a NUL-terminated string.
        let ifindex = unsafe { libc::if_nametoindex(cname.as_ptr()) } as i32;
        if ifindex == 0 || name.is_empty() {
            return Err(IfaceError::NoSuchInterface(name.to_string()));
        }
        let proto = (ETHERTYPE_ECAT).to_be() as i32;
        // SAFETY: plain socket call; the result is checked.
        let raw =
            unsafe { libc::socket(libc::AF_PACKET, libc::SOCK_RAW | libc::SOCK_CLOEXEC, proto) };
        if raw < 0 {
            let e = last_err();
            return Err(match e.kind() {
                io::ErrorKind::PermissionDenied => IfaceError::PermissionDenied(name.to_string()),
                _ => IfaceError::Io(name.to_string(), e),
            });
        }
        // SAFETY: `raw` is a fresh descriptor we own.
        let fd = unsafe { OwnedFd::from_raw_fd(raw) };
        // SAFETY: zeroed sockaddr_ll is a valid value; fields set below.
        let mut sll: libc::sockaddr_ll = unsafe { std::mem::zeroed() };
        sll.sll_family = libc::AF_PACKET as u16;
        sll.sll_protocol = ETHERTYPE_ECAT.to_be();
        sll.sll_ifindex = ifindex;
        // SAFETY: `sll` is a valid sockaddr_ll of the given size.
        let r = unsafe {
            libc::bind(
                fd.as_raw_fd(),
                &sll as *const libc::sockaddr_ll as *const libc::sockaddr,
                std::mem::size_of::<libc::sockaddr_ll>() as u32,
            )
        };
        if r < 0 {
            return Err(IfaceError::Io(name.to_string(), last_err()));
        }
        // SAFETY: zeroed packet_mreq is valid; fields set below.
        let mut mr: libc::packet_mreq = unsafe { std::mem::zeroed() };
        mr.mr_ifindex = ifindex;
        mr.mr_type = libc::PACKET_MR_PROMISC as u16;
        // SAFETY: `mr` is a valid packet_mreq of the given size.
        let r = unsafe {
            libc::setsockopt(
                fd.as_raw_fd(),
                libc::SOL_PACKET,
                libc::PACKET_ADD_MEMBERSHIP,
                &mr as *const libc::packet_mreq as *const libc::c_void,
                std::mem::size_of::<libc::packet_mreq>() as u32,
            )
        };
        if r < 0 {
            return Err(IfaceError::Io(name.to_string(), last_err()));
        }
        Ok(Self {
            fd,
            ifindex,
            name: name.to_string(),
        })
    }

    /// The interface name.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// The interface index.
    pub fn ifindex(&self) -> i32 {
        self.ifindex
    }

    /// Waits up to `timeout` for an incoming frame; `Ok(None)` on timeout. Frames this
    /// host sent out of the interface are skipped.
    pub fn recv(&self, buf: &mut [u8], timeout: Duration) -> io::Result<Option<usize>> {
        let deadline = Instant::now() + timeout;
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            let mut pfd = libc::pollfd {
                fd: self.fd.as_raw_fd(),
                events: libc::POLLIN,
                revents: 0,
            };
            let ms = left.as_millis().min(i32::MAX as u128) as i32;
            // SAFETY: one valid pollfd.
            let r = unsafe { libc::poll(&mut pfd, 1, ms) };
            if r < 0 {
                let e = last_err();
                if e.kind() == io::ErrorKind::Interrupted {
                    return Ok(None);
                }
                return Err(e);
            }
            if r == 0 {
                return Ok(None);
            }
            // SAFETY: zeroed sockaddr_ll is valid; recvfrom fills it.
            let mut from: libc::sockaddr_ll = unsafe { std::mem::zeroed() };
            let mut from_len = std::mem::size_of::<libc::sockaddr_ll>() as u32;
            // SAFETY: `buf` and `from` are valid for the given lengths.
            let n = unsafe {
                libc::recvfrom(
                    self.fd.as_raw_fd(),
                    buf.as_mut_ptr() as *mut libc::c_void,
                    buf.len(),
                    libc::MSG_DONTWAIT,
                    &mut from as *mut libc::sockaddr_ll as *mut libc::sockaddr,
                    &mut from_len,
                )
            };
            if n < 0 {
                let e = last_err();
                if matches!(
                    e.kind(),
                    io::ErrorKind::WouldBlock | io::ErrorKind::Interrupted
                ) {
                    continue;
                }
                return Err(e);
            }
            if from.sll_pkttype == libc::PACKET_OUTGOING {
                if Instant::now() >= deadline {
                    return Ok(None);
                }
                continue;
            }
            return Ok(Some(n as usize));
        }
    }

    /// Sends one Ethernet frame out of the interface.
    pub fn send(&self, frame: &[u8]) -> io::Result<()> {
        // SAFETY: `frame` is valid for its length.
        let n = unsafe {
            libc::send(
                self.fd.as_raw_fd(),
                frame.as_ptr() as *const libc::c_void,
                frame.len(),
                0,
            )
        };
        if n < 0 {
            return Err(last_err());
        }
        if n as usize != frame.len() {
            return Err(io::Error::other(format!(
                "sent {n} of {} bytes",
                frame.len()
            )));
        }
        Ok(())
    }
}

/// Options of [`serve`].
#[derive(Clone, Debug)]
pub struct ServeOptions {
    /// Stop after this long (None: until `stop` is set).
    pub duration: Option<Duration>,
    /// Longest wait for a frame before the board's time is brought up to date.
    pub tick: Duration,
    /// How often the progress callback is called.
    pub progress_every: Duration,
}

impl Default for ServeOptions {
    fn default() -> Self {
        Self {
            duration: None,
            tick: Duration::from_millis(1),
            progress_every: Duration::from_secs(1),
        }
    }
}

/// Counters of [`serve`].
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct ServeStats {
    /// Frames received and answered.
    pub frames: u64,
    /// Received frames that were not EtherCAT (or too short) and were dropped.
    pub dropped: u64,
    /// Wall time served.
    pub elapsed: Duration,
    /// AL status register (0x0130) at the last progress report.
    pub al_status: u16,
}

/// Answers every EtherCAT frame arriving on `sock` with the board, until `stop` is set or
/// the duration has passed. `progress` is called every `progress_every`.
pub fn serve(
    board: &mut VirtualBoard,
    sock: &RawSocket,
    stop: &AtomicBool,
    opts: &ServeOptions,
    progress: &mut dyn FnMut(&ServeStats),
) -> io::Result<ServeStats> {
    serve_ports(board, Some(sock), None, stop, opts, progress)
}

/// The board on the wall clock with its outside connections: EtherCAT frames on `sock` (if
/// given) and the CAN bus through `can`, a socketcand server (if given). Runs until `stop`
/// is set or the duration has passed; `progress` is called every `progress_every`.
pub fn serve_ports(
    board: &mut VirtualBoard,
    sock: Option<&RawSocket>,
    mut can: Option<&mut SocketcandServer>,
    stop: &AtomicBool,
    opts: &ServeOptions,
    progress: &mut dyn FnMut(&ServeStats),
) -> io::Result<ServeStats> {
    let start = Instant::now();
    let t0 = board.now_ns();
    let mut stats = ServeStats::default();
    let mut buf = vec![0u8; 16 * 1024];
    let mut next_progress = start + opts.progress_every;
    // Longest step of virtual time between two looks at the connections.
    let max_step = (opts.tick.as_nanos() as u64).max(1);
    // With both, neither waits long for the other.
    let tick = if sock.is_some() && can.is_some() {
        opts.tick / 4
    } else {
        opts.tick
    };
    loop {
        let now = Instant::now();
        stats.elapsed = now - start;
        if stop.load(Ordering::Relaxed) || opts.duration.is_some_and(|d| stats.elapsed >= d) {
            break;
        }
        if now >= next_progress {
            stats.al_status = board
                .esc()
                .borrow()
                .peek_u16(crate::models::esc::regs::AL_STATUS);
            progress(&stats);
            next_progress += opts.progress_every;
        }
        // Behind the wall clock: look at the connections without waiting.
        let behind = t0 + stats.elapsed.as_nanos() as u64 > board.now_ns() + max_step;
        let wait = if behind { Duration::ZERO } else { tick };
        let got = match (sock, can.as_deref()) {
            (Some(sock), _) => sock.recv(&mut buf, wait)?,
            (None, Some(server)) => {
                server.wait(wait);
                None
            }
            (None, None) => {
                std::thread::sleep(wait);
                None
            }
        };
        // Bring the board's virtual time up to the wall clock (never backwards), by at most
        // one tick per frame or wait: a board slower than real time (the image
        // co-simulator on a busy machine) then runs slow instead of leaving the frames
        // unanswered while it catches up.
        let wall = t0 + start.elapsed().as_nanos() as u64;
        if wall > board.now_ns() {
            board.step((wall - board.now_ns()).min(max_step));
        }
        if let Some(server) = can.as_deref_mut() {
            server.serve(&mut board.can().borrow_mut());
        }
        let Some(n) = got else { continue };
        let frame = &buf[..n];
        if n < 16 || u16::from_be_bytes([frame[12], frame[13]]) != ETHERTYPE_ECAT {
            stats.dropped += 1;
            continue;
        }
        let reply = board.exchange(frame);
        if let Some(sock) = sock {
            sock.send(&reply)?;
        }
        stats.frames += 1;
    }
    stats.al_status = board
        .esc()
        .borrow()
        .peek_u16(crate::models::esc::regs::AL_STATUS);
    Ok(stats)
}

/// Runs `ip ARGS` (iproute2).
pub fn ip(args: &str) -> Result<(), String> {
    let out = std::process::Command::new("ip")
        .args(args.split_whitespace())
        .output()
        .map_err(|e| format!("ip: {e}"))?;
    if out.status.success() {
        Ok(())
    } else {
        Err(format!(
            "`ip {args}` failed: {}",
            String::from_utf8_lossy(&out.stderr).trim()
        ))
    }
}

/// Why a veth pair cannot be set up here (root, iproute2), if it cannot.
pub fn veth_missing() -> Option<String> {
    // SAFETY: plain getter.
    if unsafe { libc::geteuid() } != 0 {
        return Some("not running as root".into());
    }
    if std::process::Command::new("ip").arg("-V").output().is_err() {
        return Some("`ip` (iproute2) is not installed".into());
    }
    None
}

/// Why a test with SOEM (pysoem) as the master on a veth pair cannot run here, if it cannot:
/// [`veth_missing`], or python3 with pysoem missing.
pub fn pysoem_missing() -> Option<String> {
    veth_missing().or_else(|| {
        let pysoem = std::process::Command::new("python3")
            .args(["-c", "import pysoem"])
            .output();
        (!pysoem.is_ok_and(|o| o.status.success()))
            .then(|| "python3 with pysoem is not installed (`cargo xtask setup`)".into())
    })
}

/// Moves the calling thread (and the threads it spawns from then on) into a new network
/// namespace and creates the veth pair `a` <-> `b` there, both up: nothing shows on the host,
/// and the pair goes with the namespace when the thread ends. For tests (root).
pub fn veth_pair_in_new_namespace(a: &str, b: &str) -> Result<(), String> {
    // SAFETY: affects only this thread (and threads it spawns from now on).
    if unsafe { libc::unshare(libc::CLONE_NEWNET) } != 0 {
        return Err(format!(
            "cannot create a network namespace ({})",
            io::Error::last_os_error()
        ));
    }
    ip(&format!("link add {a} type veth peer name {b}"))?;
    ip(&format!("link set {a} up"))?;
    ip(&format!("link set {b} up"))
}

static CTRL_C: AtomicBool = AtomicBool::new(false);

extern "C" fn on_sigint(_: libc::c_int) {
    CTRL_C.store(true, Ordering::SeqCst);
}

/// Installs a SIGINT (Ctrl-C) and SIGTERM handler that sets the returned flag (once per
/// process; later calls return the same flag).
pub fn ctrl_c_flag() -> &'static AtomicBool {
    static INSTALLED: std::sync::Once = std::sync::Once::new();
    INSTALLED.call_once(|| {
        let handler = on_sigint as extern "C" fn(libc::c_int) as libc::sighandler_t;
        // SAFETY: the handler only stores to an atomic (async-signal-safe).
        unsafe {
            libc::signal(libc::SIGINT, handler);
            libc::signal(libc::SIGTERM, handler);
        }
    });
    &CTRL_C
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn unknown_interface_is_a_clear_error() {
        let e = RawSocket::open("no-such-if0").unwrap_err();
        assert!(matches!(e, IfaceError::NoSuchInterface(_)), "{e:?}");
        assert!(e
            .to_string()
            .contains("unknown network interface `no-such-if0`"));
        let e = RawSocket::open("").unwrap_err();
        assert!(matches!(e, IfaceError::NoSuchInterface(_)), "{e:?}");
        let e = RawSocket::open("bad\0name").unwrap_err();
        assert!(matches!(e, IfaceError::NoSuchInterface(_)), "{e:?}");
    }
}
