//! Fuzz target: any sequence of mailbox frames into a FoE-only mailbox (the bootloader's), in
//! any ESM state, through any mailbox size, never panics; every answer fits the mailbox and
//! parses back as a mailbox error or an FoE ACK, DATA, ERR or BUSY packet.
//!
//! Input layout: byte 0 = state selector, byte 1 = mailbox size, byte 2 = clock step, byte 3 =
//! store behaviour (bit 0: answer BUSY to every other write, bit 1: refuse the finish), then
//! frames separated by the length byte in front of each.
//!
//! Run: `cargo xtask fuzz --target foe_server`.
#![no_main]

use coe_core::esm::AlState;
use coe_core::foe::{FileStore, FoeError, FoeMailbox, WriteRefusal};
use coe_core::sdo_server::Reply;
use coe_core::wire::{Foe, FoeErrorCode, FoeOpCode, FoeRepr, Mailbox, MailboxRepr, MailboxType};
use libfuzzer_sys::fuzz_target;

/// Accepts any write of "fw.efw" and serves a 300-byte file "info"; remembers nothing but the
/// length, so the target checks the server, not a file system.
struct Store {
    flags: u8,
    writes: u32,
    len: u32,
}

impl FileStore for Store {
    fn open_write(&mut self, name: &[u8], _: u32, state: AlState) -> Result<(), FoeError> {
        if state != AlState::Bootstrap {
            return Err(FoeErrorCode::BootstrapOnly.into());
        }
        if name != b"fw.efw" {
            return Err(FoeErrorCode::NotFound.into());
        }
        self.len = 0;
        Ok(())
    }

    fn write(&mut self, offset: u32, data: &[u8]) -> Result<(), WriteRefusal> {
        assert_eq!(offset, self.len, "writes come in order");
        self.writes = self.writes.wrapping_add(1);
        if self.flags & 1 != 0 && self.writes % 2 == 0 {
            return Err(WriteRefusal::Busy { done: 1, entire: 2 });
        }
        self.len += data.len() as u32;
        Ok(())
    }

    fn finish_write(&mut self, len: u32) -> Result<(), FoeError> {
        assert_eq!(len, self.len);
        if self.flags & 2 != 0 {
            return Err(FoeErrorCode::InvalidChecksum.into());
        }
        Ok(())
    }

    fn open_read(&mut self, name: &[u8], _: u32, _: AlState) -> Result<(), FoeError> {
        if name == b"info" {
            Ok(())
        } else {
            Err(FoeErrorCode::NotFound.into())
        }
    }

    fn read(&mut self, offset: u32, out: &mut [u8]) -> Result<usize, FoeError> {
        let n = 300usize.saturating_sub(offset as usize).min(out.len());
        out[..n].fill(0x5A);
        Ok(n)
    }

    fn abort(&mut self) {}
}

fuzz_target!(|data: &[u8]| {
    if data.len() < 4 {
        return;
    }
    let state = [
        AlState::Init,
        AlState::PreOp,
        AlState::Bootstrap,
        AlState::SafeOp,
        AlState::Op,
    ][usize::from(data[0]) % 5];
    let mbx = 8 + usize::from(data[1]) % 250;
    let step = u32::from(data[2]) * 100;
    let mut store = Store {
        flags: data[3],
        writes: 0,
        len: 0,
    };
    let mut server = FoeMailbox::<256>::new();
    let mut now = 0u32;
    let mut rest = &data[4..];
    while let Some((&n, tail)) = rest.split_first() {
        let n = usize::from(n).min(tail.len());
        let (frame, next) = tail.split_at(n);
        rest = next;
        let mut reply = vec![0u8; mbx];
        if let Reply::Frame(len) = server.process(frame, state, &mut store, now, &mut reply) {
            assert!(len <= mbx);
            let view = Mailbox::new_checked(&reply[..len]).expect("mailbox frame");
            let header = MailboxRepr::parse(&view).expect("header");
            match header.mailbox_type {
                MailboxType::Error => assert_eq!(header.payload_len, 4),
                MailboxType::Foe => {
                    let repr = FoeRepr::parse(&Foe::new_unchecked(view.payload())).expect("FoE");
                    assert!(matches!(
                        repr.op_code(),
                        FoeOpCode::Ack | FoeOpCode::Data | FoeOpCode::Error | FoeOpCode::Busy
                    ));
                }
                other => panic!("answer of type {other:?}"),
            }
        }
        now = now.wrapping_add(step);
    }
});
