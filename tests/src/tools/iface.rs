//! The virtual board on a real Linux network interface: an `AF_PACKET` raw socket bound
//! to EtherType 0x88A4 answers every EtherCAT frame that arrives, so any master on the
//! other side of the wire (SOEM, TwinCAT in a VM, IgH, ethercrab) can drive the board.
//!
//! The board is the (last) slave of the segment: each frame that arrives is processed by
//! the ESC model and sent back out of the same interface, as the ESC's port 0 does when
//! ports 1..3 are closed. Frames the socket itself sent (`PACKET_OUTGOING`) are skipped.
//!
//! Time, as on the module: the ESC keeps the wall clock's time, as the ET1100 keeps its
//! crystal's, and answers each frame the moment it arrives, from its state then (registers,
//! SyncManager buffers, FMMUs, working counter), in a thread of its own at real-time priority
//! when run as root. The CPU (the firmware compiled for the host, or the image on the
//! co-simulator) runs in the calling thread on the board's virtual time, stepped towards
//! the wall clock in short slices ([`ServeOptions::slice`]) and never ahead of it; it sees
//! the ESC's IRQ line at the first step after it changes, and each SYNC edge at the edge's
//! own time. A CPU slower than real time falls behind the wall clock (the lag, [`Lag`]):
//! the master then sees a slow CPU (a mailbox answered later, inputs older), never a late
//! or missing frame. SYNC0, the process-data watchdog and DC system time run at the wall
//! clock's speed, or N times slower ([`ServeOptions::slowdown`]); the ADC and the DAC at
//! the CPU's. `docs/book/frame-serving.md` tells the whole of it.
//!
//! Needs `CAP_NET_RAW` (root). Linux only.

use crate::models::shared_esc::WallClock;
use crate::models::spi::SharedEsc;
use crate::rig::board::{wire_time_ns, VirtualBoard};
use crate::tools::latency::Latency;
use crate::tools::pcap::PcapWriter;
use crate::tools::socketcand::SocketcandServer;
use std::ffi::CString;
use std::io;
use std::os::fd::{AsRawFd, FromRawFd, OwnedFd};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
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
        // The kernel's receive time stamp of every frame (the answer latency starts there);
        // without it the latency starts when the frame is read.
        let on: libc::c_int = 1;
        // SAFETY: `on` is a valid c_int of the given size.
        unsafe {
            libc::setsockopt(
                fd.as_raw_fd(),
                libc::SOL_SOCKET,
                libc::SO_TIMESTAMPNS,
                &on as *const libc::c_int as *const libc::c_void,
                std::mem::size_of::<libc::c_int>() as u32,
            )
        };
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
        Ok(self.recv_stamped(buf, timeout)?.map(|(n, _)| n))
    }

    /// [`RawSocket::recv`] with the frame's arrival time (CLOCK_REALTIME, ns): the kernel's
    /// receive time stamp, else the time it was read.
    pub fn recv_stamped(
        &self,
        buf: &mut [u8],
        timeout: Duration,
    ) -> io::Result<Option<(usize, u64)>> {
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
            // SAFETY: zeroed sockaddr_ll is valid; recvmsg fills it.
            let mut from: libc::sockaddr_ll = unsafe { std::mem::zeroed() };
            let mut iov = libc::iovec {
                iov_base: buf.as_mut_ptr() as *mut libc::c_void,
                iov_len: buf.len(),
            };
            // Room for one SCM_TIMESTAMPNS message (aligned as cmsghdr).
            let mut control = [0u64; 8];
            // SAFETY: zeroed msghdr is valid; the fields are set below.
            let mut msg: libc::msghdr = unsafe { std::mem::zeroed() };
            msg.msg_name = &mut from as *mut libc::sockaddr_ll as *mut libc::c_void;
            msg.msg_namelen = std::mem::size_of::<libc::sockaddr_ll>() as u32;
            msg.msg_iov = &mut iov;
            msg.msg_iovlen = 1;
            msg.msg_control = control.as_mut_ptr() as *mut libc::c_void;
            msg.msg_controllen = std::mem::size_of_val(&control);
            // SAFETY: `msg` points at `from`, `iov` (over `buf`) and `control`, all valid
            // for the lengths given.
            let n = unsafe { libc::recvmsg(self.fd.as_raw_fd(), &mut msg, libc::MSG_DONTWAIT) };
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
            let stamp = receive_time_stamp(&msg).unwrap_or_else(realtime_clock_ns);
            return Ok(Some((n as usize, stamp)));
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
    /// Longest wait of the CPU's thread once the CPU has caught up with the wall clock (a
    /// frame, a SYNC edge or the CPU's own next event ends it earlier).
    pub tick: Duration,
    /// The stretch of the wall clock a continuously running CPU (the image) is stepped by
    /// (on a slowed-down board, [`ServeOptions::slowdown`], that many times less of its
    /// time): at most this much between two looks at the wall clock (SYNC edges and the
    /// ESC's IRQ line reach it at this granularity), and, once it has caught up, at least
    /// this much when it runs again unless something comes from outside first.
    pub slice: Duration,
    /// How often the progress callback is called.
    pub progress_every: Duration,
    /// When allowed (root): the thread that answers frames at real-time priority
    /// ([`ANSWER_PRIORITY`]), the CPU's thread too, below it ([`CPU_PRIORITY`]).
    pub raise_priorities: bool,
    /// Wall nanoseconds per nanosecond of the board's time (1: real time): the whole board,
    /// its ESC's DC time, SYNC edges and watchdog included, runs this many times slower
    /// than the wall clock ([`WallClock`]), for a co-simulator that cannot keep up at full
    /// speed; its master then runs with a cycle this many times as long.
    pub slowdown: u32,
}

impl Default for ServeOptions {
    fn default() -> Self {
        Self {
            duration: None,
            tick: Duration::from_millis(1),
            slice: Duration::from_micros(100),
            progress_every: Duration::from_secs(1),
            raise_priorities: true,
            slowdown: 1,
        }
    }
}

/// SCHED_FIFO priority of the thread that answers frames (above the kernel's threaded
/// interrupt handlers' 50 would starve the network; below it, it still preempts every
/// normal thread at once).
pub const ANSWER_PRIORITY: i32 = 40;

/// Counters and figures of [`serve`].
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
    /// Answer latency of the frames: from the arrival on the interface (the kernel's receive
    /// time stamp) to the return of the reply's send (on a veth pair the reply has then been
    /// handed to the peer).
    pub latency: Latency,
    /// How far the board's virtual time (the CPU's) was behind the wall clock.
    pub lag: Lag,
    /// The frames were answered by a thread at real-time priority.
    pub realtime: bool,
}

/// How far the CPU's virtual time was behind the wall clock (sampled at every step of the
/// board).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Lag {
    /// At the end (ns).
    pub end_ns: u64,
    /// Largest (ns).
    pub max_ns: u64,
    /// Mean over the wall time served (ns).
    pub mean_ns: u64,
    /// Virtual time the board advanced (ns).
    pub virtual_ns: u64,
    /// The largest lag in each millisecond of the board's virtual time that was sampled:
    /// `(start of the millisecond, lag)` (ns), in order; what a check of the outputs needs to
    /// tell a slow CPU from a wrong one.
    pub trace: Vec<(u64, u64)>,
    weighted: u128,
    last: Option<(Instant, u64)>,
}

/// The stretch of virtual time one entry of [`Lag::trace`] covers (ns).
const LAG_TRACE_NS: u64 = 1_000_000;

impl Lag {
    /// The largest lag sampled while the board's virtual time was in `[from_ns, to_ns]`
    /// (to the [`Lag::trace`]'s millisecond).
    pub fn max_between(&self, from_ns: u64, to_ns: u64) -> u64 {
        let first = from_ns / LAG_TRACE_NS * LAG_TRACE_NS;
        self.trace
            .iter()
            .filter(|(t, _)| (first..=to_ns).contains(t))
            .map(|&(_, lag)| lag)
            .max()
            .unwrap_or(0)
    }

    fn trace(&mut self, virtual_ns: u64, lag_ns: u64) {
        let at = virtual_ns / LAG_TRACE_NS * LAG_TRACE_NS;
        match self.trace.last_mut() {
            Some((t, lag)) if *t == at => *lag = (*lag).max(lag_ns),
            _ => self.trace.push((at, lag_ns)),
        }
    }

    fn sample(&mut self, now: Instant, lag_ns: u64, served: Duration) {
        if let Some((at, lag)) = self.last {
            self.weighted += (now - at).as_nanos() * u128::from(lag);
        }
        self.last = Some((now, lag_ns));
        self.end_ns = lag_ns;
        self.max_ns = self.max_ns.max(lag_ns);
        self.mean_ns = self
            .weighted
            .checked_div(served.as_nanos())
            .unwrap_or(0)
            .min(u128::from(u64::MAX)) as u64;
    }

    /// "0.02 ms at the end, 3.10 ms at most, 0.05 ms on average; 9.998 s virtual in 10.000 s".
    pub fn summary(&self, served: Duration) -> String {
        format!(
            "{:.2} ms at the end, {:.2} ms at most, {:.2} ms on average; {:.3} s virtual in {:.3} s",
            self.end_ns as f64 * 1e-6,
            self.max_ns as f64 * 1e-6,
            self.mean_ns as f64 * 1e-6,
            self.virtual_ns as f64 * 1e-9,
            served.as_secs_f64()
        )
    }
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
///
/// Two threads: one answers each frame at its arrival from the ESC's state then (the ESC
/// keeps the wall clock's time, [`VirtualBoard::follow_wall_clock`]) and wakes the other,
/// this one, which steps the CPU towards the wall clock in slices of at most
/// `opts.slice` and waits once it has caught up. A CPU slower than real time falls behind
/// (the lag in the figures) but never holds a frame up.
pub fn serve_ports(
    board: &mut VirtualBoard,
    sock: Option<&RawSocket>,
    can: Option<&mut SocketcandServer>,
    stop: &AtomicBool,
    opts: &ServeOptions,
    progress: &mut dyn FnMut(&ServeStats),
) -> io::Result<ServeStats> {
    let start = Instant::now();
    let clock = board.follow_wall_clock(start, opts.slowdown);
    let esc = board.esc().clone();
    let done = AtomicBool::new(false);
    let frames = AtomicU64::new(0);
    let cpu_thread = std::thread::current();
    let pcap = board.take_pcap();
    let priority = opts.raise_priorities.then(CpuThreadPriority::raise);
    let (pcap, answered, stats) = std::thread::scope(|s| {
        let (pcap, server) = match sock {
            Some(sock) => {
                let (esc, done, frames, cpu) = (&esc, &done, &frames, &cpu_thread);
                let realtime = opts.raise_priorities;
                let server =
                    s.spawn(move || answer_frames(esc, sock, done, frames, cpu, pcap, realtime));
                (None, Some(server))
            }
            None => (pcap, None),
        };
        let answering = server.is_some();
        let stats = run_cpu(
            board, can, answering, stop, &done, &frames, opts, clock, progress,
        );
        done.store(true, Ordering::Relaxed);
        let answered = server.map(|h| {
            h.join()
                .unwrap_or_else(|_| Err(io::Error::other("the frame-answering thread panicked")))
        });
        (pcap, answered, stats)
    });
    if let Some(p) = priority {
        p.restore();
    }
    board.follow_virtual_time();
    let mut stats = stats;
    match answered {
        Some(Ok(a)) => {
            board.put_pcap(a.pcap);
            board.stats.frames += a.frames;
            stats.frames = a.frames;
            stats.dropped = a.dropped;
            stats.latency = a.latency;
            stats.realtime = a.realtime;
        }
        Some(Err(e)) => return Err(e),
        None => board.put_pcap(pcap),
    }
    stats.al_status = board
        .esc()
        .borrow()
        .peek_u16(crate::models::esc::regs::AL_STATUS);
    Ok(stats)
}

/// What the frame-answering thread did.
struct Answered {
    frames: u64,
    dropped: u64,
    latency: Latency,
    pcap: Option<PcapWriter>,
    realtime: bool,
}

/// The thread that answers frames: each one the moment it arrives, from the ESC as it is
/// then, recorded (at the ESC's time) if the board captures, with the CPU's thread woken to
/// see what the frame changed. Ends when `done` is set, or with the first failed send.
fn answer_frames(
    esc: &SharedEsc,
    sock: &RawSocket,
    done: &AtomicBool,
    frames: &AtomicU64,
    cpu: &std::thread::Thread,
    mut pcap: Option<PcapWriter>,
    realtime: bool,
) -> io::Result<Answered> {
    let realtime = realtime && set_realtime_priority(ANSWER_PRIORITY);
    let mut a = Answered {
        frames: 0,
        dropped: 0,
        latency: Latency::default(),
        pcap: None,
        realtime,
    };
    let mut buf = vec![0u8; 16 * 1024];
    let result = loop {
        if done.load(Ordering::Relaxed) {
            break Ok(());
        }
        let (n, arrival_ns) = match sock.recv_stamped(&mut buf, Duration::from_millis(20)) {
            Ok(Some(got)) => got,
            Ok(None) => continue,
            Err(e) => break Err(e),
        };
        let frame = &buf[..n];
        if n < 16 || u16::from_be_bytes([frame[12], frame[13]]) != ETHERTYPE_ECAT {
            a.dropped += 1;
            continue;
        }
        let mut reply = frame.to_vec();
        let esc_ns = {
            let mut esc = esc.borrow_mut();
            esc.process_frame(&mut reply);
            esc.now_ns()
        };
        if let Err(e) = sock.send(&reply) {
            break Err(e);
        }
        a.latency
            .record(realtime_clock_ns().saturating_sub(arrival_ns));
        cpu.unpark();
        if let Some(p) = pcap.as_mut() {
            p.record(esc_ns, frame);
            p.record(esc_ns + wire_time_ns(n), &reply);
        }
        a.frames += 1;
        frames.store(a.frames, Ordering::Relaxed);
    };
    // The CPU's thread stops with this one.
    done.store(true, Ordering::Relaxed);
    a.pcap = pcap;
    result.map(|()| a)
}

/// Shortest wait of the CPU's thread: below it, waiting costs more than it saves.
const MIN_WAIT: Duration = Duration::from_micros(5);
/// Longest wait while socketcand clients may be waiting.
const CAN_WAIT: Duration = Duration::from_millis(1);
/// How often socketcand's clients are looked at while the CPU runs.
const CAN_EVERY: Duration = Duration::from_micros(250);

/// Steps the board's CPU towards the wall clock until `stop`, `done` or the duration, with
/// the CAN bus served through socketcand if given; returns the figures of this side.
#[allow(clippy::too_many_arguments)]
fn run_cpu(
    board: &mut VirtualBoard,
    mut can: Option<&mut SocketcandServer>,
    answering: bool,
    stop: &AtomicBool,
    done: &AtomicBool,
    frames: &AtomicU64,
    opts: &ServeOptions,
    clock: WallClock,
    progress: &mut dyn FnMut(&ServeStats),
) -> ServeStats {
    let start = clock.start();
    let t0 = board.now_ns();
    // The options' durations are wall time; the loop below counts in the board's.
    let slice = clock.board_time(opts.slice).max(1);
    let tick = clock.board_time(opts.tick).max(1);
    let min_wait = clock.board_time(MIN_WAIT).max(1);
    let mut stats = ServeStats::default();
    let mut next_progress = start + opts.progress_every;
    let mut next_can = start;
    let mut seen_frames = 0;
    let wall_ns = |at: Instant| clock.at(at);
    let finished = |elapsed: Duration| {
        stop.load(Ordering::Relaxed)
            || done.load(Ordering::Relaxed)
            || opts.duration.is_some_and(|d| elapsed >= d)
    };
    loop {
        let now = Instant::now();
        stats.elapsed = now - start;
        if finished(stats.elapsed) {
            break;
        }
        if now >= next_progress {
            stats.frames = frames.load(Ordering::Relaxed);
            stats.al_status = board
                .esc()
                .borrow()
                .peek_u16(crate::models::esc::regs::AL_STATUS);
            progress(&stats);
            next_progress += opts.progress_every;
        }
        if let Some(server) = can.as_deref_mut().filter(|_| now >= next_can) {
            server.serve(&mut board.can().borrow_mut());
            next_can = now + CAN_EVERY;
        }
        let wall = wall_ns(now);
        let v = board.now_ns();
        stats.lag.sample(now, wall.saturating_sub(v), stats.elapsed);
        stats.lag.trace(v, wall.saturating_sub(v));
        let continuous = board.cpu().runs_continuously();
        // Something came from outside: a frame (its thread also wakes this one) or a SYNC
        // edge. It is handed over at once, even to a CPU that has to wait.
        let answered = frames.load(Ordering::Relaxed);
        let (edges_waiting, next_edge) = board.esc().wall_edges();
        let news = answered != seen_frames || edges_waiting;
        // The virtual time the CPU next needs to run at (a CPU called at events: none).
        let need = board.cpu_next_wake_ns().max(v);
        let run = news
            || if continuous {
                need <= wall && wall >= v + slice
            } else {
                wall >= v + tick
            };
        if run {
            seen_frames = answered;
            // Each SYNC edge reaches the CPU at its own time (the steps below stop at the
            // next edge, so none is passed). A CPU far behind runs whole cycles here: the
            // lag is traced at each edge too. A CPU slower than the wall clock never catches
            // up, so the stop requests are heard here as well.
            while !finished(start.elapsed()) && board.deliver_first_wall_edge() {
                let v = board.now_ns();
                stats
                    .lag
                    .trace(v, wall_ns(Instant::now()).saturating_sub(v));
            }
            if news {
                // An idle CPU sleeps up to now first: it sees what came when it came.
                board.idle_until(wall);
            }
            let v = board.now_ns();
            let most = if continuous { slice } else { u64::MAX };
            let to_edge = next_edge.map_or(u64::MAX, |t| t.saturating_sub(v));
            // Up to the wall clock, never ahead of it.
            board.step(wall.saturating_sub(v).min(most).min(to_edge));
            continue;
        }
        // Nothing to run: wait for a frame (its thread wakes this one), the next SYNC edge,
        // the time the CPU's next need may run (a slice ahead at least), or a tick.
        let cpu = if continuous {
            need.max(v + slice)
        } else {
            v + tick
        };
        let until = [next_edge, Some(cpu), Some(wall + tick)]
            .into_iter()
            .flatten()
            .min()
            .unwrap_or(wall + tick)
            .max(wall + min_wait);
        let wait = clock.wall_time(until - wall);
        match can.as_deref() {
            // socketcand waits in whole milliseconds; its clients are served at least once a
            // millisecond.
            Some(server) if !answering && wait >= CAN_WAIT => server.wait(wait),
            Some(_) => std::thread::park_timeout(wait.min(CAN_WAIT)),
            None => std::thread::park_timeout(wait),
        }
    }
    stats.lag.virtual_ns = board.now_ns() - t0;
    stats
}

/// The calling thread to SCHED_FIFO at `priority`; false when not allowed (not root).
fn set_realtime_priority(priority: i32) -> bool {
    let p = libc::sched_param {
        sched_priority: priority,
    };
    // SAFETY: plain call on the calling thread (pid 0) with a valid sched_param.
    unsafe { libc::sched_setscheduler(0, libc::SCHED_FIFO, &p) == 0 }
}

/// The CPU's thread while it serves: SCHED_FIFO at [`CPU_PRIORITY`] when allowed (no normal
/// thread, a compiler's included, then takes its core; the kernel's real-time throttling
/// still leaves the others 5 %), else nice -20 when allowed; and a timer slack of 1 us (its
/// short waits end on time). All restored afterwards.
struct CpuThreadPriority {
    tid: libc::id_t,
    realtime: bool,
    nice: Option<i32>,
    slack: libc::c_int,
}

/// SCHED_FIFO priority of the CPU's thread on the wall clock: below the frames' thread
/// ([`ANSWER_PRIORITY`]) and below a master's cyclic task (the project's pysoem script
/// takes 30).
pub const CPU_PRIORITY: i32 = 10;

impl CpuThreadPriority {
    fn raise() -> Self {
        let realtime =
            std::env::var_os("XX_NO_RT").is_none() && set_realtime_priority(CPU_PRIORITY);
        // SAFETY: plain getters and setters on the calling thread.
        unsafe {
            let tid = libc::gettid() as libc::id_t;
            *libc::__errno_location() = 0;
            let old = libc::getpriority(libc::PRIO_PROCESS, tid);
            let nice = (!realtime
                && *libc::__errno_location() == 0
                && libc::setpriority(libc::PRIO_PROCESS, tid, -20) == 0)
                .then_some(old);
            let slack = libc::prctl(libc::PR_GET_TIMERSLACK);
            libc::prctl(libc::PR_SET_TIMERSLACK, 1_000 as libc::c_ulong);
            Self {
                tid,
                realtime,
                nice,
                slack,
            }
        }
    }

    fn restore(self) {
        // SAFETY: as in `raise`.
        unsafe {
            if self.realtime {
                let p = libc::sched_param { sched_priority: 0 };
                libc::sched_setscheduler(0, libc::SCHED_OTHER, &p);
            }
            if let Some(n) = self.nice {
                libc::setpriority(libc::PRIO_PROCESS, self.tid, n);
            }
            if self.slack > 0 {
                libc::prctl(libc::PR_SET_TIMERSLACK, self.slack as libc::c_ulong);
            }
        }
    }
}

/// The SCM_TIMESTAMPNS of a received message (CLOCK_REALTIME, ns), if it has one.
fn receive_time_stamp(msg: &libc::msghdr) -> Option<u64> {
    // SAFETY: `msg` was filled by recvmsg; the CMSG macros walk its control buffer within
    // msg_controllen, and the data of an SCM_TIMESTAMPNS message is a timespec.
    unsafe {
        let mut c = libc::CMSG_FIRSTHDR(msg);
        while !c.is_null() {
            if (*c).cmsg_level == libc::SOL_SOCKET && (*c).cmsg_type == libc::SCM_TIMESTAMPNS {
                let ts = std::ptr::read_unaligned(libc::CMSG_DATA(c) as *const libc::timespec);
                return Some(ts.tv_sec as u64 * 1_000_000_000 + ts.tv_nsec as u64);
            }
            c = libc::CMSG_NXTHDR(msg, c);
        }
    }
    None
}

/// CLOCK_REALTIME in ns (the clock of the kernel's receive time stamps).
fn realtime_clock_ns() -> u64 {
    // SAFETY: zeroed timespec is valid; clock_gettime fills it.
    let mut ts: libc::timespec = unsafe { std::mem::zeroed() };
    // SAFETY: valid pointer to a timespec.
    unsafe { libc::clock_gettime(libc::CLOCK_REALTIME, &mut ts) };
    ts.tv_sec as u64 * 1_000_000_000 + ts.tv_nsec as u64
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
///
/// The thread also takes the machine's wall-clock slot ([`WALL_CLOCK_LOCK`]) until it ends:
/// a board on the wall clock and its master need the cores they find, and two such runs
/// side by side (two checkouts testing at once) starved each other's masters past SOEM's
/// timeouts.
pub fn veth_pair_in_new_namespace(a: &str, b: &str) -> Result<(), String> {
    take_the_wall_clock_slot(WALL_CLOCK_WAIT)?;
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

/// The lock file of the machine's wall-clock slot (`flock`, released when its holder ends).
pub const WALL_CLOCK_LOCK: &str = "/tmp/virtual-board-wall-clock.lock";
/// How long a test waits for the wall-clock slot: longer than the longest veth test.
pub const WALL_CLOCK_WAIT: Duration = Duration::from_secs(15 * 60);

thread_local! {
    /// The slot's lock, held by the thread that took it until the thread ends.
    static WALL_CLOCK_SLOT: std::cell::RefCell<Option<OwnedFd>> =
        const { std::cell::RefCell::new(None) };
}

/// Takes the machine's wall-clock slot for the calling thread (until it ends), waiting up to
/// `wait` for another process or thread holding it.
pub fn take_the_wall_clock_slot(wait: Duration) -> Result<(), String> {
    take_slot(WALL_CLOCK_LOCK, wait)
}

/// Takes the `flock` on `lock` for the calling thread (until it ends), waiting up to `wait`.
fn take_slot(lock: &str, wait: Duration) -> Result<(), String> {
    if WALL_CLOCK_SLOT.with(|s| s.borrow().is_some()) {
        return Ok(());
    }
    let path = CString::new(lock).map_err(|e| e.to_string())?;
    // SAFETY: plain open of a NUL-terminated path; the fd is owned below.
    let fd = unsafe {
        libc::open(
            path.as_ptr(),
            libc::O_CREAT | libc::O_RDWR | libc::O_CLOEXEC,
            0o666,
        )
    };
    if fd < 0 {
        return Err(format!("cannot open {lock}: {}", last_err()));
    }
    // SAFETY: `fd` was just opened and is owned by nothing else.
    let fd = unsafe { OwnedFd::from_raw_fd(fd) };
    let deadline = Instant::now() + wait;
    loop {
        // SAFETY: flock on a valid fd.
        if unsafe { libc::flock(fd.as_raw_fd(), libc::LOCK_EX | libc::LOCK_NB) } == 0 {
            WALL_CLOCK_SLOT.with(|s| *s.borrow_mut() = Some(fd));
            return Ok(());
        }
        if Instant::now() >= deadline {
            return Err(format!(
                "another board on the wall clock held {lock} for {} s",
                wait.as_secs()
            ));
        }
        std::thread::sleep(Duration::from_millis(50));
    }
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
    fn the_wall_clock_slot_is_one_threads_until_it_ends() {
        let lock = std::env::temp_dir().join(format!("wall-clock-slot-{}", std::process::id()));
        let lock = lock.to_str().unwrap().to_string();
        let (taken_tx, taken_rx) = std::sync::mpsc::channel();
        let (end_tx, end_rx) = std::sync::mpsc::channel::<()>();
        let l = lock.clone();
        let holder = std::thread::spawn(move || {
            take_slot(&l, Duration::ZERO).unwrap();
            taken_tx.send(()).unwrap();
            end_rx.recv().unwrap();
        });
        taken_rx.recv().unwrap();
        let l = lock.clone();
        let err = std::thread::spawn(move || take_slot(&l, Duration::from_millis(100)))
            .join()
            .unwrap()
            .unwrap_err();
        assert!(
            err.contains("another board on the wall clock held"),
            "{err}"
        );
        end_tx.send(()).unwrap();
        holder.join().unwrap();
        let l = lock.clone();
        std::thread::spawn(move || take_slot(&l, Duration::from_secs(5)))
            .join()
            .unwrap()
            .unwrap();
        std::fs::remove_file(&lock).unwrap();
    }

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
