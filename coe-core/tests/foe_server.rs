//! The FoE server through the mailbox: property tests (random frames never panic it and
//! every answer is a well-formed frame; files of random length written and read through
//! random mailbox sizes arrive whole, also with BUSY answers in between) and CoE + FoE on one
//! mailbox (shared counters and repeat backup).

mod server_common;

use coe_core::esm::AlState;
use coe_core::foe::{FileStore, FoeEndpoint, FoeError, FoeMailbox, FoeServer, WriteRefusal};
use coe_core::sdo_server::{Reply, SdoServer};
use coe_core::wire::{Foe, FoeErrorCode, FoeOpCode, FoeRepr, Mailbox, MailboxRepr, MailboxType};
use proptest::prelude::*;
use server_common::*;

/// One writable and one readable file in memory; BUSY on chosen offsets.
#[derive(Default)]
struct Store {
    writing: Vec<u8>,
    committed: Option<Vec<u8>>,
    readable: Vec<u8>,
    busy: Vec<u32>,
    open: bool,
}

impl FileStore for Store {
    fn open_write(&mut self, name: &[u8], password: u32, state: AlState) -> Result<(), FoeError> {
        if state != AlState::Bootstrap {
            return Err(FoeErrorCode::BootstrapOnly.into());
        }
        if name != b"image.efw" || password != 0 {
            return Err(FoeErrorCode::NotFound.into());
        }
        self.writing.clear();
        self.open = true;
        Ok(())
    }

    fn write(&mut self, offset: u32, data: &[u8]) -> Result<(), WriteRefusal> {
        assert!(self.open, "write without open");
        if let Some(i) = self.busy.iter().position(|b| *b == offset) {
            self.busy.remove(i);
            return Err(WriteRefusal::Busy { done: 0, entire: 1 });
        }
        assert_eq!(offset as usize, self.writing.len());
        self.writing.extend_from_slice(data);
        Ok(())
    }

    fn finish_write(&mut self, len: u32) -> Result<(), FoeError> {
        assert_eq!(len as usize, self.writing.len());
        self.committed = Some(std::mem::take(&mut self.writing));
        self.open = false;
        Ok(())
    }

    fn open_read(&mut self, name: &[u8], _: u32, _: AlState) -> Result<(), FoeError> {
        if name == b"readme" {
            self.open = true;
            Ok(())
        } else {
            Err(FoeErrorCode::NotFound.into())
        }
    }

    fn read(&mut self, offset: u32, out: &mut [u8]) -> Result<usize, FoeError> {
        let rest = self.readable.get(offset as usize..).unwrap_or(&[]);
        let n = rest.len().min(out.len());
        out[..n].copy_from_slice(&rest[..n]);
        Ok(n)
    }

    fn abort(&mut self) {
        self.open = false;
    }
}

/// A whole write-mailbox buffer of `mbx` bytes with `payload` of `mailbox_type`.
fn frame(mbx: usize, mailbox_type: u8, counter: u8, payload: &[u8]) -> Vec<u8> {
    let mut f = vec![0u8; mbx];
    f[0..2].copy_from_slice(&(payload.len() as u16).to_le_bytes());
    f[5] = mailbox_type | (counter << 4);
    f[6..6 + payload.len()].copy_from_slice(payload);
    f
}

fn packet(repr: FoeRepr<'_>) -> Vec<u8> {
    let mut out = vec![0u8; repr.buffer_len()];
    repr.emit(&mut Foe::new_unchecked(&mut out[..])).unwrap();
    out
}

/// A frame the FoE mailbox may send: a mailbox error, or an FoE ACK, DATA, ERR or BUSY.
fn assert_well_formed(reply: &[u8], mbx: usize) {
    let view = Mailbox::new_checked(reply).expect("mailbox frame");
    let header = MailboxRepr::parse(&view).unwrap();
    assert!(header.buffer_len() <= mbx);
    assert!((1..=7).contains(&header.counter));
    match header.mailbox_type {
        MailboxType::Error => assert_eq!(header.payload_len, 4),
        MailboxType::Foe => {
            let repr = FoeRepr::parse(&Foe::new_unchecked(view.payload())).expect("FoE");
            assert!(
                matches!(
                    repr.op_code(),
                    FoeOpCode::Ack | FoeOpCode::Data | FoeOpCode::Error | FoeOpCode::Busy
                ),
                "{repr:?}"
            );
        }
        other => panic!("type {other:?}"),
    }
}

/// A master writing `content` to the FoE mailbox through a mailbox of `mbx` bytes; returns
/// the answers' op codes.
fn write_through(mbx: usize, content: &[u8], store: &mut Store) -> Vec<FoeRepr<'static>> {
    let mut server = FoeMailbox::<256>::new();
    server.on_state_change(AlState::Init, AlState::Bootstrap, store);
    let mut counter = 0u8;
    let mut send = |server: &mut FoeMailbox<256>, store: &mut Store, p: &[u8]| {
        counter = counter % 7 + 1;
        let mut reply = vec![0u8; mbx];
        let r = server.process(
            &frame(mbx, 4, counter, p),
            AlState::Bootstrap,
            store,
            0,
            &mut reply,
        );
        let n = r.frame_len().expect("an answer");
        assert_well_formed(&reply[..n], mbx);
        let repr = FoeRepr::parse(&Foe::new_unchecked(&reply[6..n])).unwrap();
        match repr {
            FoeRepr::Ack { packet_number } => FoeRepr::Ack { packet_number },
            FoeRepr::Busy { done, entire, .. } => FoeRepr::Busy {
                done,
                entire,
                text: &[],
            },
            FoeRepr::Error { code, .. } => FoeRepr::error(code),
            other => panic!("{other:?}"),
        }
    };
    let mut answers = vec![send(
        &mut server,
        store,
        &packet(FoeRepr::WriteRequest {
            password: 0,
            file_name: b"image.efw",
        }),
    )];
    let room = mbx - 12;
    let mut offset = 0;
    let mut number = 1u32;
    loop {
        let chunk = &content[offset..(offset + room).min(content.len())];
        let answer = send(
            &mut server,
            store,
            &packet(FoeRepr::Data {
                packet_number: number,
                data: chunk,
            }),
        );
        answers.push(answer);
        match answer {
            FoeRepr::Busy { .. } => continue, // the same packet again
            FoeRepr::Ack { packet_number } => assert_eq!(packet_number, number),
            other => panic!("{other:?}"),
        }
        offset += chunk.len();
        number += 1;
        if chunk.len() < room {
            break;
        }
    }
    answers
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    #[test]
    fn random_frames_never_panic_and_get_well_formed_answers(
        frames in prop::collection::vec(prop::collection::vec(any::<u8>(), 0..80), 1..20),
        mbx in 13usize..96,
        state in prop::sample::select(vec![AlState::Init, AlState::PreOp, AlState::Bootstrap]),
        clock_step in 0u32..20_000,
    ) {
        let mut server = FoeMailbox::<128>::new();
        let mut store = Store { readable: (0..300).map(|i| i as u8).collect(), ..Store::default() };
        let mut now = 0u32;
        for (i, raw) in frames.iter().enumerate() {
            // Half of them FoE frames with a valid header around random bytes.
            let request = if i % 2 == 0 {
                let mut f = raw.clone();
                f.resize(mbx, 0);
                f
            } else {
                let p = &raw[..raw.len().min(mbx - 6)];
                frame(mbx, 4, (i % 7) as u8 + 1, p)
            };
            let mut reply = vec![0u8; mbx];
            if let Reply::Frame(n) = server.process(&request, state, &mut store, now, &mut reply) {
                assert_well_formed(&reply[..n], mbx);
            }
            now = now.wrapping_add(clock_step);
        }
    }

    #[test]
    fn files_are_written_whole_through_any_mailbox(
        len in 0usize..1500,
        // Room for the write request with its name.
        mbx in 21usize..200,
        busy_at in prop::collection::vec(0usize..1500, 0..4),
    ) {
        let content: Vec<u8> = (0..len).map(|i| (i * 31 + 7) as u8).collect();
        let room = mbx - 12;
        // BUSY only where a packet starts.
        let busy = busy_at.iter().map(|b| (b / room * room).min(len / room * room) as u32).collect();
        let mut store = Store { busy, ..Store::default() };
        let answers = write_through(mbx, &content, &mut store);
        prop_assert_eq!(store.committed.as_deref(), Some(&content[..]));
        let acks = answers.iter().filter(|a| matches!(a, FoeRepr::Ack { .. })).count();
        prop_assert_eq!(acks, len / room + 2);
    }

    #[test]
    fn files_are_read_whole_through_any_mailbox(len in 0usize..1500, mbx in 13usize..200) {
        let readable: Vec<u8> = (0..len).map(|i| (i * 13 + 1) as u8).collect();
        let mut server = FoeServer::new();
        let mut store = Store { readable: readable.clone(), ..Store::default() };
        let mut out = vec![0u8; mbx - 6];
        let mut got = Vec::new();
        let mut request = packet(FoeRepr::ReadRequest { password: 0, file_name: b"readme" });
        let mut expect = 1;
        loop {
            let n = server
                .process(&request, mbx, AlState::PreOp, &mut store, 0, &mut out)
                .unwrap();
            let Some(n) = n else { break };
            let repr = FoeRepr::parse(&Foe::new_unchecked(&out[..n])).unwrap();
            let FoeRepr::Data { packet_number, data } = repr else { panic!("{repr:?}") };
            prop_assert_eq!(packet_number, expect);
            prop_assert!(data.len() <= mbx - 12);
            got.extend_from_slice(data);
            request = packet(FoeRepr::Ack { packet_number });
            expect += 1;
        }
        prop_assert_eq!(got, readable);
        prop_assert!(!server.busy());
    }
}

#[test]
fn coe_and_foe_share_counters_and_the_repeat_backup() {
    let mut sdo: SdoServer<128, 512, 2> = SdoServer::new();
    let mut foe = FoeServer::new();
    let mut store = Store::default();
    let mut app = App::new();
    let mut reply = [0u8; 128];
    let process = |sdo: &mut SdoServer<128, 512, 2>,
                   foe: &mut FoeServer,
                   store: &mut Store,
                   app: &mut App,
                   request: &[u8],
                   reply: &mut [u8; 128]| {
        let mut endpoint = FoeEndpoint {
            server: foe,
            files: store,
        };
        sdo.process_with(
            request,
            AlState::PreOp,
            &OD,
            app,
            0,
            &mut reply[..],
            &mut endpoint,
        )
    };
    // CoE: SDO upload of 0x1000:00, counter 1 -> reply counter 1.
    let sdo_req = [0x00, 0x20, 0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0];
    let r = process(
        &mut sdo,
        &mut foe,
        &mut store,
        &mut app,
        &frame(128, 3, 1, &sdo_req),
        &mut reply,
    );
    assert!(matches!(r, Reply::Frame(_)));
    assert_eq!(Mailbox::new_checked(&reply[..]).unwrap().counter(), 1);
    // FoE write request in PREOP, counter 2 -> "bootstrap only" with reply counter 2.
    let wrq = packet(FoeRepr::WriteRequest {
        password: 0,
        file_name: b"image.efw",
    });
    let r = process(
        &mut sdo,
        &mut foe,
        &mut store,
        &mut app,
        &frame(128, 4, 2, &wrq),
        &mut reply,
    );
    let n = r.frame_len().unwrap();
    let view = Mailbox::new_checked(&reply[..n]).unwrap();
    assert_eq!(view.mailbox_type(), MailboxType::Foe);
    assert_eq!(view.counter(), 2);
    assert_eq!(
        FoeRepr::parse(&Foe::new_unchecked(view.payload())),
        Ok(FoeRepr::error(FoeErrorCode::BootstrapOnly))
    );
    // The same counter 2 again, now as CoE: a retry for the shared mailbox, dropped.
    let r = process(
        &mut sdo,
        &mut foe,
        &mut store,
        &mut app,
        &frame(128, 3, 2, &sdo_req),
        &mut reply,
    );
    assert_eq!(r, Reply::None);
    // The repeat request gives the FoE answer.
    let mut again = [0u8; 128];
    assert_eq!(sdo.repeat(&mut again), Reply::Frame(n));
    assert_eq!(again[..n], reply[..n]);
    // Without a protocol beside CoE, FoE is an unsupported protocol.
    let r = sdo.process(
        &frame(128, 4, 3, &wrq),
        AlState::PreOp,
        &OD,
        &mut app,
        0,
        &mut reply,
    );
    let n = r.frame_len().unwrap();
    assert_eq!(&reply[5..n], &[0x30, 0x01, 0x00, 0x02, 0x00]);
}
