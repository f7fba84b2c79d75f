//! The SDO server on CAN (CiA 301 7.2.4): the CAN framing of the one SDO state machine,
//! [`crate::sdo_server::machine::SdoMachine`].
//!
//! A request is a data frame of 8 bytes on 0x600 + node-ID, the answer a data frame of 8
//! bytes on 0x580 + node-ID; the SDO frame is the whole data field. Because the answer has
//! 8 bytes, a value of more than 4 bytes is uploaded as an initiate response carrying only
//! its size followed by segments of 7 bytes, and a download that is not expedited carries
//! its size in the initiate request and its data in segments. Complete access (a CoE
//! extension) does not exist on CAN: the bit is reserved there, and a request that sets it
//! is refused with 0x05040001. A frame with fewer than 8 data bytes, or a remote frame, is
//! not an SDO request and is ignored.

use super::cob;
use super::frame::CanFrame;
use crate::od::ObjectAccess;
use crate::sdo_server::machine::{SdoContext, SdoMachine};
use crate::wire::Sdo;

/// Data bytes of every SDO frame on CAN.
pub const SDO_FRAME_LEN: usize = 8;

/// The SDO server of one node; `BUF` is the largest value moved in segments.
#[derive(Debug, Clone)]
pub struct CanSdoServer<const BUF: usize> {
    machine: SdoMachine<BUF>,
}

impl<const BUF: usize> Default for CanSdoServer<BUF> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const BUF: usize> CanSdoServer<BUF> {
    /// A server with nothing in progress.
    pub const fn new() -> Self {
        Self {
            machine: SdoMachine::new(false),
        }
    }

    /// Sets the time a segmented transfer may wait for its next request.
    pub fn set_timeout_ms(&mut self, timeout_ms: u32) {
        self.machine.set_timeout_ms(timeout_ms);
    }

    /// Drops a transfer in progress (NMT reset, or the node left the states with SDO).
    pub fn reset(&mut self) {
        self.machine.reset();
    }

    /// True while a segmented transfer is open.
    pub fn busy(&self) -> bool {
        self.machine.busy()
    }

    /// Serves a frame that arrived on 0x600 + `node`: the answer for 0x580 + `node`, or
    /// `None` (no answer: an abort from the client, or not an SDO request).
    pub fn receive<A: ObjectAccess + ?Sized>(
        &mut self,
        node: u8,
        request: &CanFrame,
        ctx: SdoContext<'_, A>,
    ) -> Option<CanFrame> {
        if request.is_remote() || request.data().len() != SDO_FRAME_LEN {
            return None;
        }
        let view = Sdo::new_checked(request.data()).ok()?;
        let mut out = [0u8; SDO_FRAME_LEN];
        // Every SDO frame the machine writes into 8 bytes is 8 bytes long (initiate and
        // abort frames are 8, segments are padded to 7 data bytes).
        self.machine.serve(&view, ctx, &mut out)?;
        CanFrame::new(cob::SDO_TX + u16::from(node), &out).ok()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::abort::SdoAbortCode;
    use crate::esm::AlState;
    use crate::od::{Access, DataType, EntryDesc, ObjectDesc, ObjectDictionary, OdStore, Value};

    static OD: ObjectDictionary = ObjectDictionary::new(&[
        ObjectDesc::var(
            0x1000,
            "Device type",
            &[
                EntryDesc::new(0, "Device type", DataType::Unsigned32, Access::RO)
                    .with_default(Value::Uint(0x000C_0191)),
            ],
        ),
        ObjectDesc::var(
            0x1008,
            "Device name",
            &[EntryDesc::string(0, "Device name", "Analog IO 8AI 2AO")],
        ),
        ObjectDesc::var(
            0x2000,
            "U8",
            &[EntryDesc::new(0, "U8", DataType::Unsigned8, Access::RW)],
        ),
        ObjectDesc::var(
            0x2001,
            "Text",
            &[EntryDesc::new(0, "Text", DataType::VisibleString, Access::RW).with_bits(16 * 8)],
        ),
        ObjectDesc::record(
            0x2002,
            "Record",
            DataType::Unknown(0x40),
            &[
                EntryDesc::count(1),
                EntryDesc::new(1, "U16", DataType::Unsigned16, Access::RW),
            ],
        ),
    ]);

    struct Bench {
        server: CanSdoServer<64>,
        store: OdStore<256>,
    }

    impl Bench {
        fn new() -> Self {
            Self {
                server: CanSdoServer::new(),
                store: OdStore::new(OD).unwrap(),
            }
        }

        fn ask(&mut self, data: [u8; 8]) -> Option<[u8; 8]> {
            let frame = CanFrame::new(0x605, &data).unwrap();
            let ctx = SdoContext {
                state: AlState::PreOp,
                od: &OD,
                app: &mut self.store,
                now_ms: 0,
            };
            let reply = self.server.receive(5, &frame, ctx)?;
            assert_eq!(reply.id(), 0x585);
            Some(reply.data().try_into().unwrap())
        }
    }

    #[test]
    fn expedited_upload_and_download() {
        let mut b = Bench::new();
        assert_eq!(
            b.ask([0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0]),
            Some([0x43, 0x00, 0x10, 0x00, 0x91, 0x01, 0x0C, 0x00])
        );
        assert_eq!(
            b.ask([0x2F, 0x00, 0x20, 0x00, 0x7B, 0, 0, 0]),
            Some([0x60, 0x00, 0x20, 0x00, 0, 0, 0, 0])
        );
        assert_eq!(
            b.ask([0x40, 0x00, 0x20, 0x00, 0, 0, 0, 0]),
            Some([0x4F, 0x00, 0x20, 0x00, 0x7B, 0, 0, 0])
        );
    }

    #[test]
    fn segmented_upload_in_seven_byte_segments() {
        let mut b = Bench::new();
        // "Analog IO 8AI 2AO" is 17 bytes: size in the initiate response, then 7 + 7 + 3.
        assert_eq!(
            b.ask([0x40, 0x08, 0x10, 0x00, 0, 0, 0, 0]),
            Some([0x41, 0x08, 0x10, 0x00, 17, 0, 0, 0])
        );
        assert_eq!(b.ask([0x60, 0, 0, 0, 0, 0, 0, 0]), Some(*b"\x00Analog "));
        assert_eq!(b.ask([0x70, 0, 0, 0, 0, 0, 0, 0]), Some(*b"\x10IO 8AI "));
        // Last segment: 3 bytes, n = 4 unused, c = 1: 0x00 | 4 << 1 | 1 = 0x09.
        assert_eq!(
            b.ask([0x60, 0, 0, 0, 0, 0, 0, 0]),
            Some(*b"\x092AO\0\0\0\0")
        );
        // Toggle error.
        b.ask([0x40, 0x08, 0x10, 0x00, 0, 0, 0, 0]);
        let abort = b.ask([0x70, 0, 0, 0, 0, 0, 0, 0]).unwrap();
        assert_eq!(abort[..4], [0x80, 0x08, 0x10, 0x00]);
        assert_eq!(
            u32::from_le_bytes(abort[4..].try_into().unwrap()),
            u32::from(SdoAbortCode::ToggleBitNotAlternated)
        );
    }

    #[test]
    fn segmented_download() {
        let mut b = Bench::new();
        assert_eq!(
            b.ask([0x21, 0x01, 0x20, 0x00, 10, 0, 0, 0]),
            Some([0x60, 0x01, 0x20, 0x00, 0, 0, 0, 0])
        );
        assert_eq!(b.ask(*b"\x00abcdefg"), Some([0x20, 0, 0, 0, 0, 0, 0, 0]));
        // 3 bytes, 4 unused, last: 0x10 | 4 << 1 | 1 = 0x19.
        assert_eq!(
            b.ask(*b"\x19hij\0\0\0\0"),
            Some([0x30, 0, 0, 0, 0, 0, 0, 0])
        );
        let mut text = [0u8; 16];
        let n = b.store.read(0x2001, 0, &mut text).unwrap();
        assert_eq!(&text[..n], b"abcdefghij");
    }

    #[test]
    fn complete_access_bit_is_reserved_on_can() {
        let mut b = Bench::new();
        let abort = b.ask([0x50, 0x02, 0x20, 0x00, 0, 0, 0, 0]).unwrap();
        assert_eq!(abort[0], 0x80);
        assert_eq!(
            u32::from_le_bytes(abort[4..].try_into().unwrap()),
            u32::from(SdoAbortCode::InvalidCommandSpecifier)
        );
    }

    #[test]
    fn short_and_remote_frames_are_not_sdo_requests() {
        fn ctx(store: &mut OdStore<256>) -> SdoContext<'_, OdStore<256>> {
            SdoContext {
                state: AlState::PreOp,
                od: &OD,
                app: store,
                now_ms: 0,
            }
        }
        let mut b = Bench::new();
        let short = CanFrame::new(0x605, &[0x40, 0, 0x10, 0]).unwrap();
        assert_eq!(b.server.receive(5, &short, ctx(&mut b.store)), None);
        let remote = CanFrame::remote(0x605, 8).unwrap();
        assert_eq!(b.server.receive(5, &remote, ctx(&mut b.store)), None);
        // An abort from the client gets no answer.
        assert_eq!(b.ask([0x80, 0, 0x10, 0, 0, 0, 0, 0]), None);
    }
}
