use super::*;
use crate::wire::{Mailbox, MailboxErrorReply, MailboxErrorReplyRepr};
use std::vec::Vec;

/// A write mailbox of 64 bytes: 52 bytes of file data per full packet.
const MBX: usize = 64;
const ROOM: usize = MBX - 12;

/// Files in memory: one writable name, one readable file; every call logged.
#[derive(Default)]
struct Memory {
    written: Vec<u8>,
    committed: Option<Vec<u8>>,
    readable: Vec<u8>,
    busy_once_at: Option<u32>,
    refuse_finish: Option<FoeError>,
    write_only: bool,
    log: Vec<&'static str>,
}

impl FileStore for Memory {
    fn reads(&self) -> bool {
        !self.write_only
    }

    fn open_write(&mut self, name: &[u8], password: u32, state: AlState) -> Result<(), FoeError> {
        self.log.push("open_write");
        if state != AlState::Bootstrap {
            return Err(FoeError::new(FoeErrorCode::BootstrapOnly));
        }
        if name != b"fw.efw" {
            return Err(FoeError::new(FoeErrorCode::NotFound));
        }
        if password != 7 {
            return Err(FoeError::with_text(FoeErrorCode::NoRights, "password"));
        }
        self.written.clear();
        Ok(())
    }

    fn write(&mut self, offset: u32, data: &[u8]) -> Result<(), WriteRefusal> {
        self.log.push("write");
        if self.busy_once_at == Some(offset) {
            self.busy_once_at = None;
            return Err(WriteRefusal::Busy { done: 1, entire: 4 });
        }
        assert_eq!(offset as usize, self.written.len(), "writes come in order");
        self.written.extend_from_slice(data);
        Ok(())
    }

    fn finish_write(&mut self, len: u32) -> Result<(), FoeError> {
        self.log.push("finish");
        assert_eq!(len as usize, self.written.len());
        if let Some(e) = self.refuse_finish {
            return Err(e);
        }
        self.committed = Some(self.written.clone());
        Ok(())
    }

    fn open_read(&mut self, name: &[u8], _password: u32, _state: AlState) -> Result<(), FoeError> {
        self.log.push("open_read");
        if name == b"info.txt" {
            Ok(())
        } else {
            Err(FoeError::new(FoeErrorCode::NotFound))
        }
    }

    fn read(&mut self, offset: u32, out: &mut [u8]) -> Result<usize, FoeError> {
        let rest = self.readable.get(offset as usize..).unwrap_or(&[]);
        let n = rest.len().min(out.len());
        out[..n].copy_from_slice(&rest[..n]);
        Ok(n)
    }

    fn abort(&mut self) {
        self.log.push("abort");
    }
}

fn packet(repr: FoeRepr<'_>) -> Vec<u8> {
    let mut out = std::vec![0u8; repr.buffer_len()];
    repr.emit(&mut Foe::new_unchecked(&mut out[..])).unwrap();
    out
}

struct Rig {
    server: FoeServer,
    files: Memory,
    state: AlState,
    now_ms: u32,
}

impl Rig {
    fn new() -> Self {
        Self {
            server: FoeServer::new(),
            files: Memory::default(),
            state: AlState::Bootstrap,
            now_ms: 0,
        }
    }

    /// Sends one packet; the parsed answer (owned) or the mailbox error.
    fn send(&mut self, repr: FoeRepr<'_>) -> Result<Option<Answer>, MailboxErrorCode> {
        self.send_raw(&packet(repr))
    }

    fn send_raw(&mut self, bytes: &[u8]) -> Result<Option<Answer>, MailboxErrorCode> {
        let mut out = [0u8; MBX - 6];
        let n = self.server.process(
            bytes,
            MBX,
            self.state,
            &mut self.files,
            self.now_ms,
            &mut out,
        )?;
        Ok(n.map(|n| {
            let view = Foe::new_unchecked(&out[..n]);
            Answer::of(FoeRepr::parse(&view).unwrap())
        }))
    }
}

#[derive(Debug, Clone, PartialEq, Eq)]
enum Answer {
    Ack(u32),
    Data(u32, Vec<u8>),
    Error(FoeErrorCode, String),
    Busy(u16, u16),
}

impl Answer {
    fn of(repr: FoeRepr<'_>) -> Self {
        match repr {
            FoeRepr::Ack { packet_number } => Self::Ack(packet_number),
            FoeRepr::Data {
                packet_number,
                data,
            } => Self::Data(packet_number, data.to_vec()),
            FoeRepr::Error { code, text } => {
                Self::Error(code, String::from_utf8(text.to_vec()).unwrap())
            }
            FoeRepr::Busy { done, entire, .. } => Self::Busy(done, entire),
            other => panic!("a server never sends {other:?}"),
        }
    }
}

use std::string::String;

fn wrq() -> FoeRepr<'static> {
    FoeRepr::WriteRequest {
        password: 7,
        file_name: b"fw.efw",
    }
}

fn data(n: u32, bytes: &[u8]) -> FoeRepr<'_> {
    FoeRepr::Data {
        packet_number: n,
        data: bytes,
    }
}

fn file(len: usize) -> Vec<u8> {
    (0..len).map(|i| (i * 7 + 3) as u8).collect()
}

/// Writes `content` in full packets and a short last one; returns the answers.
fn write_file(rig: &mut Rig, content: &[u8]) -> Vec<Answer> {
    let mut answers = std::vec![rig.send(wrq()).unwrap().unwrap()];
    let mut chunks: Vec<&[u8]> = content.chunks(ROOM).collect();
    if content.len() % ROOM == 0 {
        chunks.push(&[]);
    }
    for (i, chunk) in chunks.iter().enumerate() {
        answers.push(rig.send(data(i as u32 + 1, chunk)).unwrap().unwrap());
    }
    answers
}

#[test]
fn write_in_packets_with_a_short_last_one() {
    for len in [0, 1, ROOM - 1, ROOM, ROOM + 1, 3 * ROOM, 3 * ROOM + 5] {
        let mut rig = Rig::new();
        let content = file(len);
        let answers = write_file(&mut rig, &content);
        let expected: Vec<Answer> = (0..answers.len() as u32).map(Answer::Ack).collect();
        assert_eq!(answers, expected, "len {len}");
        assert_eq!(rig.files.committed.as_deref(), Some(&content[..]));
        assert!(!rig.server.busy());
        assert_eq!(rig.files.log.first(), Some(&"open_write"));
        assert_eq!(rig.files.log.last(), Some(&"finish"));
        assert!(!rig.files.log.contains(&"abort"));
    }
}

#[test]
fn open_write_refusals_are_sent_with_their_code_and_text() {
    let mut rig = Rig::new();
    let wrong_name = FoeRepr::WriteRequest {
        password: 7,
        file_name: b"other.bin",
    };
    assert_eq!(
        rig.send(wrong_name).unwrap(),
        Some(Answer::Error(FoeErrorCode::NotFound, "Not found".into()))
    );
    let wrong_password = FoeRepr::WriteRequest {
        password: 8,
        file_name: b"fw.efw",
    };
    assert_eq!(
        rig.send(wrong_password).unwrap(),
        Some(Answer::Error(FoeErrorCode::NoRights, "password".into()))
    );
    rig.state = AlState::PreOp;
    assert_eq!(
        rig.send(wrq()).unwrap(),
        Some(Answer::Error(
            FoeErrorCode::BootstrapOnly,
            "Bootstrap only".into()
        ))
    );
    assert!(!rig.server.busy());
    // Nothing was opened, so nothing is aborted.
    assert!(!rig.files.log.contains(&"abort"));
}

#[test]
fn wrong_packet_number_ends_the_write() {
    let mut rig = Rig::new();
    rig.send(wrq()).unwrap();
    assert_eq!(
        rig.send(data(1, &file(ROOM))).unwrap(),
        Some(Answer::Ack(1))
    );
    assert_eq!(
        rig.send(data(3, &file(ROOM))).unwrap(),
        Some(Answer::Error(
            FoeErrorCode::PacketNumberWrong,
            "Packet number wrong".into()
        ))
    );
    assert_eq!(rig.files.log.last(), Some(&"abort"));
    // The transfer is gone: packet 2 now has no write to belong to.
    assert_eq!(
        rig.send(data(2, &file(3))).unwrap(),
        Some(Answer::Error(
            FoeErrorCode::Illegal,
            "DATA without a write in progress".into()
        ))
    );
    assert!(rig.files.committed.is_none());
}

#[test]
fn a_repeated_packet_is_a_wrong_packet_number() {
    let mut rig = Rig::new();
    rig.send(wrq()).unwrap();
    rig.send(data(1, &file(ROOM))).unwrap();
    assert!(matches!(
        rig.send(data(1, &file(ROOM))).unwrap(),
        Some(Answer::Error(FoeErrorCode::PacketNumberWrong, _))
    ));
}

#[test]
fn busy_asks_for_the_same_packet_again() {
    let mut rig = Rig::new();
    rig.files.busy_once_at = Some(ROOM as u32);
    let content = file(2 * ROOM + 3);
    rig.send(wrq()).unwrap();
    assert_eq!(
        rig.send(data(1, &content[..ROOM])).unwrap(),
        Some(Answer::Ack(1))
    );
    assert_eq!(
        rig.send(data(2, &content[ROOM..2 * ROOM])).unwrap(),
        Some(Answer::Busy(1, 4))
    );
    assert_eq!(
        rig.send(data(2, &content[ROOM..2 * ROOM])).unwrap(),
        Some(Answer::Ack(2))
    );
    assert_eq!(
        rig.send(data(3, &content[2 * ROOM..])).unwrap(),
        Some(Answer::Ack(3))
    );
    assert_eq!(rig.files.committed.as_deref(), Some(&content[..]));
}

#[test]
fn a_refused_finish_replaces_the_last_ack() {
    let mut rig = Rig::new();
    rig.files.refuse_finish = Some(FoeError::with_text(
        FoeErrorCode::InvalidChecksum,
        "bad CRC",
    ));
    let answers = write_file(&mut rig, &file(ROOM + 2));
    assert_eq!(
        answers,
        [
            Answer::Ack(0),
            Answer::Ack(1),
            Answer::Error(FoeErrorCode::InvalidChecksum, "bad CRC".into())
        ]
    );
    assert_eq!(rig.files.log.last(), Some(&"abort"));
    assert!(!rig.server.busy());
}

#[test]
fn data_longer_than_the_mailbox_is_illegal() {
    let mut rig = Rig::new();
    rig.send(wrq()).unwrap();
    assert!(matches!(
        rig.send(data(1, &file(ROOM + 1))).unwrap(),
        Some(Answer::Error(FoeErrorCode::Illegal, _))
    ));
}

#[test]
fn a_stalled_write_times_out() {
    let mut rig = Rig::new();
    rig.server.set_timeout_ms(100);
    rig.send(wrq()).unwrap();
    rig.now_ms = 100;
    assert_eq!(
        rig.send(data(1, &file(ROOM))).unwrap(),
        Some(Answer::Ack(1))
    );
    rig.now_ms = 201;
    assert_eq!(
        rig.send(data(2, &file(ROOM))).unwrap(),
        Some(Answer::Error(
            FoeErrorCode::NotDefined,
            "transfer timed out".into()
        ))
    );
    assert_eq!(rig.files.log.last(), Some(&"abort"));
    // A new request after the timeout starts afresh.
    rig.now_ms = 10_000;
    assert_eq!(rig.send(wrq()).unwrap(), Some(Answer::Ack(0)));
    // The clock wraps.
    rig.now_ms = u32::MAX;
    let mut rig2 = Rig::new();
    rig2.now_ms = u32::MAX - 10;
    rig2.send(wrq()).unwrap();
    rig2.now_ms = 20;
    assert_eq!(rig2.send(data(1, &file(3))).unwrap(), Some(Answer::Ack(1)));
}

#[test]
fn the_masters_error_ends_the_transfer_silently() {
    let mut rig = Rig::new();
    rig.send(wrq()).unwrap();
    assert_eq!(
        rig.send(FoeRepr::error(FoeErrorCode::NotDefined)).unwrap(),
        None
    );
    assert_eq!(rig.files.log.last(), Some(&"abort"));
    assert!(!rig.server.busy());
    // Without a transfer too.
    assert_eq!(
        rig.send(FoeRepr::error(FoeErrorCode::NotDefined)).unwrap(),
        None
    );
}

#[test]
fn a_new_request_ends_the_old_transfer() {
    let mut rig = Rig::new();
    rig.send(wrq()).unwrap();
    rig.send(data(1, &file(ROOM))).unwrap();
    assert_eq!(rig.send(wrq()).unwrap(), Some(Answer::Ack(0)));
    assert_eq!(
        rig.files.log,
        ["open_write", "write", "abort", "open_write"]
    );
    assert_eq!(rig.send(data(1, &file(2))).unwrap(), Some(Answer::Ack(1)));
    assert_eq!(rig.files.committed.as_deref(), Some(&file(2)[..]));
}

#[test]
fn a_state_change_ends_the_transfer() {
    let mut rig = Rig::new();
    rig.send(wrq()).unwrap();
    rig.server
        .on_state_change(AlState::Bootstrap, AlState::Init, &mut rig.files);
    assert_eq!(rig.files.log.last(), Some(&"abort"));
    assert!(!rig.server.busy());
    // Without a transfer nothing is aborted.
    rig.server
        .on_state_change(AlState::Init, AlState::Bootstrap, &mut rig.files);
    assert_eq!(rig.files.log.iter().filter(|c| **c == "abort").count(), 1);
}

#[test]
fn read_in_packets_acknowledged_one_by_one() {
    for len in [0usize, 5, ROOM, ROOM + 1, 2 * ROOM] {
        let mut rig = Rig::new();
        rig.files.readable = file(len);
        let rrq = FoeRepr::ReadRequest {
            password: 0,
            file_name: b"info.txt",
        };
        let mut got = Vec::new();
        let mut answer = rig.send(rrq).unwrap();
        let mut expect = 1;
        loop {
            let Some(Answer::Data(n, bytes)) = answer else {
                panic!("{answer:?}")
            };
            assert_eq!(n, expect);
            got.extend_from_slice(&bytes);
            let last = bytes.len() < ROOM;
            answer = rig.send(FoeRepr::Ack { packet_number: n }).unwrap();
            if last {
                assert_eq!(answer, None, "the last ACK ends the read");
                break;
            }
            expect += 1;
        }
        assert_eq!(got, rig.files.readable, "len {len}");
        assert!(!rig.server.busy());
    }
}

#[test]
fn read_errors() {
    let mut rig = Rig::new();
    let rrq = |name: &'static [u8]| FoeRepr::ReadRequest {
        password: 0,
        file_name: name,
    };
    assert_eq!(
        rig.send(rrq(b"nothing")).unwrap(),
        Some(Answer::Error(FoeErrorCode::NotFound, "Not found".into()))
    );
    rig.files.readable = file(3 * ROOM);
    rig.send(rrq(b"info.txt")).unwrap();
    assert_eq!(
        rig.send(FoeRepr::Ack { packet_number: 2 }).unwrap(),
        Some(Answer::Error(
            FoeErrorCode::PacketNumberWrong,
            "Packet number wrong".into()
        ))
    );
    assert_eq!(
        rig.send(FoeRepr::Ack { packet_number: 1 }).unwrap(),
        Some(Answer::Error(
            FoeErrorCode::Illegal,
            "ACK without a read in progress".into()
        ))
    );
    // DATA during a read, BUSY from the master: illegal.
    rig.send(rrq(b"info.txt")).unwrap();
    assert!(matches!(
        rig.send(data(1, b"x")).unwrap(),
        Some(Answer::Error(FoeErrorCode::Illegal, _))
    ));
    assert!(matches!(
        rig.send(FoeRepr::Busy {
            done: 0,
            entire: 0,
            text: &[]
        })
        .unwrap(),
        Some(Answer::Error(FoeErrorCode::Illegal, _))
    ));
}

#[test]
fn a_write_only_store_is_never_asked_to_read() {
    let mut rig = Rig::new();
    rig.files.write_only = true;
    rig.files.readable = file(3 * ROOM);
    assert_eq!(
        rig.send(FoeRepr::ReadRequest {
            password: 0,
            file_name: b"info.txt",
        })
        .unwrap(),
        Some(Answer::Error(FoeErrorCode::NotFound, "Not found".into()))
    );
    assert!(!rig.files.log.contains(&"open_read"));
    assert!(matches!(
        rig.send(FoeRepr::Ack { packet_number: 1 }).unwrap(),
        Some(Answer::Error(FoeErrorCode::Illegal, _))
    ));
    let content = file(2 * ROOM + 5);
    assert_eq!(write_file(&mut rig, &content).last(), Some(&Answer::Ack(3)));
    assert_eq!(rig.files.committed, Some(content));
}

#[test]
fn packets_that_are_not_foe_get_mailbox_errors() {
    let mut rig = Rig::new();
    assert_eq!(
        rig.send_raw(&[2, 0, 0]),
        Err(MailboxErrorCode::SizeTooShort)
    );
    assert_eq!(
        rig.send_raw(&[9, 0, 0, 0, 0, 0]),
        Err(MailboxErrorCode::InvalidHeader)
    );
}

#[test]
fn error_texts_are_cut_to_the_mailbox() {
    let mut server = FoeServer::new();
    let mut files = Memory::default();
    let mut out = [0u8; 9];
    let n = server
        .process(
            &packet(FoeRepr::WriteRequest {
                password: 0,
                file_name: b"x",
            }),
            MBX,
            AlState::Init,
            &mut files,
            0,
            &mut out,
        )
        .unwrap()
        .unwrap();
    assert_eq!(n, 9);
    assert_eq!(&out[6..], b"Boo");
}

/// A whole frame for [`FoeMailbox`]: mailbox header with `counter`, then `repr`.
fn frame(counter: u8, repr: FoeRepr<'_>) -> [u8; MBX] {
    let mut f = [0u8; MBX];
    let p = packet(repr);
    f[0..2].copy_from_slice(&(p.len() as u16).to_le_bytes());
    f[5] = 0x04 | counter << 4;
    f[6..6 + p.len()].copy_from_slice(&p);
    f
}

#[test]
fn foe_mailbox_numbers_answers_and_drops_duplicates() {
    let mut mbx = FoeMailbox::<MBX>::new();
    let mut files = Memory::default();
    let mut reply = [0u8; MBX];
    mbx.on_state_change(AlState::Init, AlState::Bootstrap, &mut files);
    let r = mbx.process(
        &frame(1, wrq()),
        AlState::Bootstrap,
        &mut files,
        0,
        &mut reply,
    );
    assert_eq!(r, Reply::Frame(12));
    let view = Mailbox::new_checked(&reply[..12]).unwrap();
    assert_eq!(view.mailbox_type(), MailboxType::Foe);
    assert_eq!(view.counter(), 1);
    assert_eq!(
        FoeRepr::parse(&Foe::new_unchecked(view.payload())),
        Ok(FoeRepr::Ack { packet_number: 0 })
    );
    // The same counter again: a retry, dropped.
    assert_eq!(
        mbx.process(
            &frame(1, wrq()),
            AlState::Bootstrap,
            &mut files,
            0,
            &mut reply
        ),
        Reply::None
    );
    // The repeat request writes the last answer again.
    let mut again = [0u8; MBX];
    assert_eq!(mbx.repeat(&mut again), Reply::Frame(12));
    assert_eq!(again[..12], reply[..12]);
    // Next packet: next counter.
    let r = mbx.process(
        &frame(2, data(1, b"abc")),
        AlState::Bootstrap,
        &mut files,
        0,
        &mut reply,
    );
    assert_eq!(r, Reply::Frame(12));
    assert_eq!(Mailbox::new_checked(&reply[..]).unwrap().counter(), 2);
    assert_eq!(files.committed.as_deref(), Some(&b"abc"[..]));
}

#[test]
fn foe_mailbox_refuses_coe_with_a_mailbox_error() {
    let mut mbx = FoeMailbox::<MBX>::new();
    let mut files = Memory::default();
    // An SDO upload request of 0x1000:00.
    let mut coe = [0u8; MBX];
    coe[0] = 10;
    coe[5] = 0x13;
    coe[6..12].copy_from_slice(&[0x00, 0x20, 0x40, 0x00, 0x10, 0x00]);
    let mut reply = [0u8; MBX];
    let r = mbx.process(&coe, AlState::Bootstrap, &mut files, 0, &mut reply);
    assert_eq!(r, Reply::Frame(10));
    let view = Mailbox::new_checked(&reply[..10]).unwrap();
    assert_eq!(view.mailbox_type(), MailboxType::Error);
    assert_eq!(
        MailboxErrorReplyRepr::parse(&MailboxErrorReply::new_unchecked(view.payload())),
        Ok(MailboxErrorReplyRepr {
            code: MailboxErrorCode::UnsupportedProtocol
        })
    );
}
