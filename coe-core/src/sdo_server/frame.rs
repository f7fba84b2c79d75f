//! Byte layout of the frames the server reads and writes (ETG.1000.4 table 29 mailbox header,
//! ETG.1000.6 5.6 CoE). STOPGAP: kept minimal and private until the shared `wire` layer
//! lands; then these functions become thin calls into it.

/// Mailbox header length.
pub(crate) const MBX_HDR: usize = 6;
/// CoE header length.
pub(crate) const COE_HDR: usize = 2;
/// Mailbox type: error reply.
pub(crate) const TYPE_ERROR: u8 = 0;
/// Mailbox type: CoE.
pub(crate) const TYPE_COE: u8 = 3;

/// CoE services (ETG.1000.6 table 29).
pub(crate) const SVC_EMERGENCY: u8 = 1;
pub(crate) const SVC_SDO_REQUEST: u8 = 2;
pub(crate) const SVC_SDO_RESPONSE: u8 = 3;
pub(crate) const SVC_SDO_INFO: u8 = 8;

/// The 6-byte mailbox header.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct MbxHeader {
    pub(crate) length: u16,
    pub(crate) address: u16,
    pub(crate) channel: u8,
    pub(crate) priority: u8,
    pub(crate) mailbox_type: u8,
    pub(crate) counter: u8,
}

impl MbxHeader {
    pub(crate) fn parse(frame: &[u8]) -> Option<Self> {
        let h = frame.get(..MBX_HDR)?;
        let [l0, l1, a0, a1, b4, b5] = [h[0], h[1], h[2], h[3], h[4], h[5]];
        Some(Self {
            length: u16::from_le_bytes([l0, l1]),
            address: u16::from_le_bytes([a0, a1]),
            channel: b4 & 0x3F,
            priority: b4 >> 6,
            mailbox_type: b5 & 0x0F,
            counter: (b5 >> 4) & 0x07,
        })
    }

    pub(crate) fn emit(&self, out: &mut [u8]) -> Option<()> {
        let h = out.get_mut(..MBX_HDR)?;
        h[..2].copy_from_slice(&self.length.to_le_bytes());
        h[2..4].copy_from_slice(&self.address.to_le_bytes());
        h[4] = (self.channel & 0x3F) | (self.priority << 6);
        h[5] = (self.mailbox_type & 0x0F) | ((self.counter & 0x07) << 4);
        Some(())
    }
}

/// The CoE service of a CoE header (bits 12..15 of the little-endian u16).
pub(crate) fn coe_service(data: &[u8]) -> Option<u8> {
    data.get(1).map(|b| b >> 4)
}

/// Writes a CoE header (number 0) for `service`.
pub(crate) fn emit_coe(out: &mut [u8], service: u8) -> Option<()> {
    let h = out.get_mut(..COE_HDR)?;
    h[0] = 0;
    h[1] = service << 4;
    Some(())
}

/// Writes CoE header + SDO header (command, index, subindex, 4 bytes) + `data` into `out`
/// (the bytes after the mailbox header); returns the mailbox data length.
pub(crate) fn emit_sdo(
    out: &mut [u8],
    service: u8,
    command: u8,
    index: u16,
    subindex: u8,
    head: [u8; 4],
    data: &[u8],
) -> Option<usize> {
    let len = COE_HDR + 8 + data.len();
    let out = out.get_mut(..len)?;
    emit_coe(out, service)?;
    let (sdo, rest) = out.get_mut(COE_HDR..)?.split_at_mut(8);
    sdo[0] = command;
    sdo[1..3].copy_from_slice(&index.to_le_bytes());
    sdo[3] = subindex;
    sdo[4..8].copy_from_slice(&head);
    rest.copy_from_slice(data);
    Some(len)
}

/// Writes CoE header + segment command + `data`, padded with zeros to the 7-byte minimum
/// segment; returns the mailbox data length.
pub(crate) fn emit_segment(out: &mut [u8], command: u8, data: &[u8]) -> Option<usize> {
    let seg = data.len().max(7);
    let len = COE_HDR + 1 + seg;
    let out = out.get_mut(..len)?;
    emit_coe(out, SVC_SDO_RESPONSE)?;
    let (cmd, rest) = out.get_mut(COE_HDR..)?.split_at_mut(1);
    cmd[0] = command;
    let (payload, pad) = rest.split_at_mut(data.len());
    payload.copy_from_slice(data);
    pad.fill(0);
    Some(len)
}

/// Writes CoE header + SDO Information header in front of `body_len` bytes the caller has
/// put at `out[6..]`; returns the mailbox data length.
pub(crate) fn emit_info_header(
    out: &mut [u8],
    opcode: u8,
    incomplete: bool,
    fragments_left: u16,
    body_len: usize,
) -> Option<usize> {
    let head = out.get_mut(..COE_HDR + 4)?;
    emit_coe(head, SVC_SDO_INFO)?;
    head[2] = (opcode & 0x7F) | if incomplete { 0x80 } else { 0 };
    head[3] = 0;
    head[4..6].copy_from_slice(&fragments_left.to_le_bytes());
    Some(COE_HDR + 4 + body_len)
}
