//! A socketcand server (the ASCII protocol of linux-can's socketcand, `doc/protocol.md`) on
//! a TCP port, so programs outside the process reach the board's CAN bus: python-can's
//! `socketcand` interface (`can.Bus(interface="socketcand", host=..., port=...,
//! channel="can0")`) and, through it, python-canopen, cantools or any CANopen master.
//!
//! Each client is one node on the [`CanBus`]: the frames it sends compete in arbitration
//! like the board's, and it receives every frame of the other nodes, not its own (as a
//! Linux raw CAN socket). What is served, per client:
//!
//! | client -> server | answer |
//! |---|---|
//! | (connect) | `< hi >` |
//! | `< open can0 >` | `< ok >` (the one bus, [`BUS_NAME`]); another name: `< error ... >` and the connection closes |
//! | `< rawmode >` | `< ok >`; from then on every frame of the bus as `< frame ID SECS.USECS DATA >` (data as contiguous hex digits, as socketcand writes them) or `< rtr ID SECS.USECS DLC >` |
//! | `< send ID DLC B0 .. >` | the data frame goes on the bus (no answer) |
//! | `< sendrtr ID DLC >` | the remote frame goes on the bus |
//! | `< echo >` | `< echo >` |
//! | anything else (BCM mode commands, 29-bit identifiers, bad syntax) | `< error ... >` naming the problem |
//!
//! Time stamps are the bus's virtual time. Frames are held back for [`RAWMODE_HOLD`] after
//! the `< ok >` of `< rawmode >`: python-can reads that answer with one `recv` and compares
//! it with `< ok >`, so a frame in the same TCP segment would break its handshake. No UDP
//! discovery beacon is sent: clients name host and port.

use crate::models::can::{CanBus, PortId};
use coe_core::canopen::CanFrame;
use std::io::{self, Read, Write};
use std::net::{SocketAddr, TcpListener, TcpStream};
use std::os::fd::AsRawFd;
use std::time::{Duration, Instant};

/// The name of the bus (`< open can0 >`).
pub const BUS_NAME: &str = "can0";

/// How long frames wait after the `< ok >` of `< rawmode >` (see the module documentation).
pub const RAWMODE_HOLD: Duration = Duration::from_millis(50);

/// Longest command accepted (socketcand's own limit is about the same).
const MAX_COMMAND: usize = 128;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Mode {
    NoBus,
    Bcm,
    Raw { since: Instant },
}

struct Client {
    stream: TcpStream,
    peer: SocketAddr,
    mode: Mode,
    port: Option<PortId>,
    input: Vec<u8>,
    output: Vec<u8>,
    closing: bool,
}

/// Counters of the server.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct ServerStats {
    /// Connections accepted.
    pub connections: u64,
    /// Frames clients put on the bus.
    pub frames_in: u64,
    /// Frames sent to clients.
    pub frames_out: u64,
    /// Commands answered with an error.
    pub errors: u64,
}

/// The server.
pub struct SocketcandServer {
    listener: TcpListener,
    clients: Vec<Client>,
    /// Counters.
    pub stats: ServerStats,
}

/// Parses `< send ID DLC B0 .. >` / `< sendrtr ID DLC >` arguments.
fn parse_frame(args: &[&str], remote: bool) -> Result<CanFrame, String> {
    let (id, rest) = args
        .split_first()
        .ok_or_else(|| "missing CAN-ID".to_string())?;
    if id.len() > 3 {
        return Err(format!(
            "CAN-ID {id}: only 11-bit identifiers (3 hex digits) are on this bus"
        ));
    }
    let id = u16::from_str_radix(id, 16).map_err(|_| format!("CAN-ID {id} is not hex"))?;
    let (dlc, data) = rest
        .split_first()
        .ok_or_else(|| "missing DLC".to_string())?;
    let dlc: u8 = dlc
        .parse()
        .map_err(|_| format!("DLC {dlc} is not a number"))?;
    if dlc > 8 {
        return Err(format!("DLC {dlc} is above 8"));
    }
    if remote {
        if !data.is_empty() {
            return Err("a remote frame carries no data".into());
        }
        return CanFrame::remote(id, dlc).map_err(|e| format!("{e:?}"));
    }
    if data.len() != usize::from(dlc) {
        return Err(format!("DLC {dlc} but {} data bytes", data.len()));
    }
    let bytes = data
        .iter()
        .map(|b| u8::from_str_radix(b, 16).map_err(|_| format!("data byte {b} is not hex")))
        .collect::<Result<Vec<u8>, String>>()?;
    CanFrame::new(id, &bytes).map_err(|e| format!("{e:?}"))
}

/// The text a client in raw mode gets for a frame that ended at `t_ns`.
pub fn frame_text(t_ns: u64, frame: &CanFrame) -> String {
    let secs = t_ns / 1_000_000_000;
    let usecs = t_ns % 1_000_000_000 / 1000;
    if frame.is_remote() {
        return format!(
            "< rtr {:03X} {secs}.{usecs:06} {} >",
            frame.id(),
            frame.dlc()
        );
    }
    let data: String = frame.data().iter().map(|b| format!("{b:02X}")).collect();
    format!("< frame {:03X} {secs}.{usecs:06} {data} >", frame.id())
}

impl Client {
    fn say(&mut self, text: &str) {
        self.output.extend_from_slice(text.as_bytes());
    }

    fn error(&mut self, stats: &mut ServerStats, what: &str) {
        stats.errors += 1;
        self.say(&format!("< error {what} >"));
    }

    /// One command (the text between `<` and `>`).
    fn command(&mut self, text: &str, bus: &mut CanBus, stats: &mut ServerStats) {
        let words: Vec<&str> = text.split_whitespace().collect();
        let Some((&verb, args)) = words.split_first() else {
            return self.error(stats, "empty command");
        };
        match (self.mode, verb) {
            (_, "echo") => self.say("< echo >"),
            (Mode::NoBus, "open") => {
                if args == [BUS_NAME] {
                    self.port = Some(bus.attach(&format!("socketcand {}", self.peer)));
                    self.mode = Mode::Bcm;
                    self.say("< ok >");
                } else {
                    self.error(
                        stats,
                        &format!("no bus {} (this server has {BUS_NAME})", args.join(" ")),
                    );
                    self.closing = true;
                }
            }
            (Mode::NoBus, _) => self.error(stats, &format!("open a bus first ({verb})")),
            (Mode::Bcm | Mode::Raw { .. }, "rawmode") => {
                self.mode = Mode::Raw {
                    since: Instant::now(),
                };
                self.say("< ok >");
            }
            (Mode::Bcm | Mode::Raw { .. }, "send" | "sendrtr") => {
                match parse_frame(args, verb == "sendrtr") {
                    Ok(frame) => {
                        if let Some(port) = self.port {
                            bus.send(port, frame);
                            stats.frames_in += 1;
                        }
                    }
                    Err(e) => self.error(stats, &e),
                }
            }
            (_, other) => self.error(
                stats,
                &format!("{other} is not served (raw mode, send, sendrtr and echo are)"),
            ),
        }
    }

    /// Reads what the client sent; false when the connection is gone.
    fn read(&mut self) -> bool {
        let mut buf = [0u8; 1024];
        loop {
            match self.stream.read(&mut buf) {
                Ok(0) => return false,
                Ok(n) => self.input.extend_from_slice(&buf[..n]),
                Err(e) if e.kind() == io::ErrorKind::WouldBlock => return true,
                Err(e) if e.kind() == io::ErrorKind::Interrupted => continue,
                Err(_) => return false,
            }
        }
    }

    /// The complete commands in the input, in order; garbage between commands is dropped,
    /// an overlong command is an error.
    fn commands(&mut self, stats: &mut ServerStats) -> Vec<String> {
        let mut out = Vec::new();
        loop {
            let Some(start) = self.input.iter().position(|b| *b == b'<') else {
                self.input.clear();
                break;
            };
            let Some(len) = self.input[start..].iter().position(|b| *b == b'>') else {
                self.input.drain(..start);
                if self.input.len() > MAX_COMMAND {
                    self.input.clear();
                    self.error(stats, "command too long");
                }
                break;
            };
            let text = String::from_utf8_lossy(&self.input[start + 1..start + len]).into_owned();
            self.input.drain(..start + len + 1);
            out.push(text);
        }
        out
    }

    /// Writes what waits; false when the connection is gone.
    fn flush(&mut self) -> bool {
        while !self.output.is_empty() {
            match self.stream.write(&self.output) {
                Ok(0) => return false,
                Ok(n) => {
                    self.output.drain(..n);
                }
                Err(e) if e.kind() == io::ErrorKind::WouldBlock => return true,
                Err(e) if e.kind() == io::ErrorKind::Interrupted => continue,
                Err(_) => return false,
            }
        }
        true
    }
}

impl SocketcandServer {
    /// Listens on `127.0.0.1:port` (port 0: any free port, see
    /// [`SocketcandServer::port`]).
    pub fn bind(port: u16) -> io::Result<Self> {
        let listener = TcpListener::bind(("127.0.0.1", port))?;
        listener.set_nonblocking(true)?;
        Ok(Self {
            listener,
            clients: Vec::new(),
            stats: ServerStats::default(),
        })
    }

    /// The TCP port.
    pub fn port(&self) -> u16 {
        self.listener.local_addr().map_or(0, |a| a.port())
    }

    /// Connected clients.
    pub fn clients(&self) -> usize {
        self.clients.len()
    }

    /// Waits up to `timeout` for a connection or a command (poll(2) on the sockets).
    pub fn wait(&self, timeout: Duration) {
        let mut fds: Vec<libc::pollfd> = std::iter::once(self.listener.as_raw_fd())
            .chain(self.clients.iter().map(|c| c.stream.as_raw_fd()))
            .map(|fd| libc::pollfd {
                fd,
                events: libc::POLLIN,
                revents: 0,
            })
            .collect();
        let ms = timeout.as_millis().min(i32::MAX as u128) as i32;
        // SAFETY: `fds` is a valid array of pollfd of the given length.
        unsafe {
            libc::poll(fds.as_mut_ptr(), fds.len() as libc::nfds_t, ms);
        }
    }

    /// Accepts connections, serves the commands that came (frames go onto `bus`) and sends
    /// the clients the frames the bus delivered to them.
    pub fn serve(&mut self, bus: &mut CanBus) {
        while let Ok((stream, peer)) = self.listener.accept() {
            let _ = stream.set_nonblocking(true);
            let _ = stream.set_nodelay(true);
            self.stats.connections += 1;
            let mut client = Client {
                stream,
                peer,
                mode: Mode::NoBus,
                port: None,
                input: Vec::new(),
                output: Vec::new(),
                closing: false,
            };
            client.say("< hi >");
            self.clients.push(client);
        }
        let stats = &mut self.stats;
        self.clients.retain_mut(|c| {
            let mut alive = c.read();
            for cmd in c.commands(stats) {
                c.command(&cmd, bus, stats);
            }
            if let (Mode::Raw { since }, Some(port)) = (c.mode, c.port) {
                if since.elapsed() >= RAWMODE_HOLD {
                    while let Some((t, frame)) = bus.receive(port) {
                        c.say(&frame_text(t, &frame));
                        stats.frames_out += 1;
                    }
                }
            }
            alive &= c.flush() && !c.closing;
            if !alive {
                if let Some(port) = c.port {
                    bus.detach(port);
                }
            }
            alive
        });
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frame_texts() {
        let f = CanFrame::new(0x185, &[0x01, 0xAB]).unwrap();
        assert_eq!(
            frame_text(23_424_242_000, &f),
            "< frame 185 23.424242 01AB >"
        );
        let empty = CanFrame::new(0x080, &[]).unwrap();
        assert_eq!(frame_text(1_000, &empty), "< frame 080 0.000001  >");
        let r = CanFrame::remote(0x705, 1).unwrap();
        assert_eq!(frame_text(0, &r), "< rtr 705 0.000000 1 >");
    }

    #[test]
    fn send_commands() {
        assert_eq!(
            parse_frame(
                &["605", "8", "40", "0", "10", "0", "0", "0", "0", "0"],
                false
            ),
            Ok(CanFrame::new(0x605, &[0x40, 0, 0x10, 0, 0, 0, 0, 0]).unwrap())
        );
        assert_eq!(
            parse_frame(&["80", "0"], false),
            Ok(CanFrame::new(0x80, &[]).unwrap())
        );
        assert_eq!(
            parse_frame(&["705", "1"], true),
            Ok(CanFrame::remote(0x705, 1).unwrap())
        );
        assert!(parse_frame(&["1AAAAAAA", "0"], false)
            .unwrap_err()
            .contains("11-bit"));
        assert!(parse_frame(&["605", "2", "1"], false)
            .unwrap_err()
            .contains("DLC 2 but 1"));
        assert!(parse_frame(&["605", "9"], false)
            .unwrap_err()
            .contains("above 8"));
        assert!(parse_frame(&["6G5", "0"], false)
            .unwrap_err()
            .contains("not hex"));
        assert!(parse_frame(&[], false).unwrap_err().contains("missing"));
    }

    /// A raw TCP client of the tests.
    struct TestClient {
        tcp: TcpStream,
    }

    impl TestClient {
        fn connect(server: &SocketcandServer) -> Self {
            let tcp = TcpStream::connect(("127.0.0.1", server.port())).unwrap();
            tcp.set_read_timeout(Some(Duration::from_millis(20)))
                .unwrap();
            Self { tcp }
        }

        fn send(&mut self, text: &str) {
            self.tcp.write_all(text.as_bytes()).unwrap();
        }

        /// Serves until the client has received `want`; everything received.
        fn expect(
            &mut self,
            server: &mut SocketcandServer,
            bus: &mut CanBus,
            want: &str,
        ) -> String {
            let mut got = String::new();
            let deadline = Instant::now() + Duration::from_secs(5);
            while !got.contains(want) {
                assert!(
                    Instant::now() < deadline,
                    "waited for {want:?}, got {got:?}"
                );
                server.serve(bus);
                let mut buf = [0u8; 512];
                if let Ok(n) = self.tcp.read(&mut buf) {
                    got.push_str(&String::from_utf8_lossy(&buf[..n]));
                }
            }
            got
        }
    }

    /// A raw TCP client through the whole protocol, against a bus with one other node.
    #[test]
    fn a_client_session() {
        let mut server = SocketcandServer::bind(0).unwrap();
        let mut bus = CanBus::new(500_000);
        let board = bus.attach("board");
        let mut wrong = TestClient::connect(&server);
        assert_eq!(wrong.expect(&mut server, &mut bus, "< hi >"), "< hi >");
        wrong.send("< open can1 >");
        assert!(wrong
            .expect(&mut server, &mut bus, "< error")
            .contains("no bus can1"));
        let mut c = TestClient::connect(&server);
        c.expect(&mut server, &mut bus, "< hi >");
        c.send("< open can0 >");
        c.expect(&mut server, &mut bus, "< ok >");
        c.send("< rawmode >");
        c.expect(&mut server, &mut bus, "< ok >");
        // The client sends a frame: it reaches the board in bus time.
        c.send("< send 605 8 40 0 10 0 0 0 0 0 >< echo >");
        c.expect(&mut server, &mut bus, "< echo >");
        bus.advance_to(1_000_000);
        assert_eq!(
            bus.receive(board).map(|(_, f)| f),
            Some(CanFrame::new(0x605, &[0x40, 0, 0x10, 0, 0, 0, 0, 0]).unwrap())
        );
        // The board answers: the client gets it, not its own frame.
        bus.send(
            board,
            CanFrame::new(0x585, &[0x43, 0, 0x10, 0, 0x91, 1, 0x0C, 0]).unwrap(),
        );
        bus.advance_to(2_000_000);
        let text = c.expect(&mut server, &mut bus, "< frame 585");
        assert!(
            text.contains("< frame 585 0.00") && text.contains(" 4300100091010C00 >"),
            "{text}"
        );
        assert!(!text.contains("frame 605"));
        c.send("< subscribe 0 0 123 >");
        assert!(c
            .expect(&mut server, &mut bus, "< error")
            .contains("subscribe is not served"));
        assert_eq!(server.stats.frames_in, 1);
        assert_eq!(server.stats.frames_out, 1);
        drop(c);
        drop(wrong);
        let deadline = Instant::now() + Duration::from_secs(5);
        while server.clients() > 0 {
            assert!(Instant::now() < deadline, "closed connections are dropped");
            server.serve(&mut bus);
        }
    }
}
