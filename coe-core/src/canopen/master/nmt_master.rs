//! The NMT master's frames (CiA 301 7.2.8.3.1): module control commands on 0x000, to one
//! node or, with node-ID 0, to all; and the node guarding request, a remote frame on
//! 0x700 + node-ID asking for the one-byte state answer.

use super::super::cob;
use super::super::frame::CanFrame;
use super::super::nmt::{NmtCommand, NmtCommandRepr};

/// Node-ID 0 in a module control command: every node.
pub const ALL_NODES: u8 = 0;

/// The module control frame of `command` for `node` (0: all nodes).
pub fn command_frame(command: NmtCommand, node: u8) -> Option<CanFrame> {
    CanFrame::new(cob::NMT, &NmtCommandRepr { command, node }.emit()).ok()
}

/// The node guarding request of `node`: a remote frame asking for one byte.
pub fn guard_request(node: u8) -> Option<CanFrame> {
    CanFrame::remote(cob::NMT_ERROR_CONTROL + u16::from(node), 1).ok()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn golden_frames() {
        let f = command_frame(NmtCommand::StartRemoteNode, 5).unwrap();
        assert_eq!((f.id(), f.data()), (0x000, &[0x01, 0x05][..]));
        let f = command_frame(NmtCommand::ResetCommunication, ALL_NODES).unwrap();
        assert_eq!(f.data(), &[0x82, 0x00]);
        let f = command_frame(NmtCommand::EnterPreOperational, 127).unwrap();
        assert_eq!(f.data(), &[0x80, 0x7F]);
        let g = guard_request(5).unwrap();
        assert!(g.is_remote());
        assert_eq!((g.id(), g.dlc()), (0x705, 1));
    }
}
