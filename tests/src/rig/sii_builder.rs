//! A tiny SII EEPROM image builder for tests (ETG.2010 layout, hardware-facts section 2).
//!
//! Test support only: the project's SII/ESI generator produces the real image. This
//! builds just enough for a master to identify the device, size the process image from
//! the PDO categories and configure SyncManagers/FMMUs.

use crate::models::esc::sii_crc8;

/// A SyncManager entry of category 41.
#[derive(Clone, Copy, Debug)]
pub struct SiiSyncManager {
    /// Physical start address.
    pub start: u16,
    /// Default length.
    pub len: u16,
    /// Control byte (0x26 mbx out, 0x22 mbx in, 0x64 outputs, 0x20 inputs).
    pub control: u8,
    /// Enable byte (b0 enable).
    pub enable: u8,
    /// Type: 1 MbxOut, 2 MbxIn, 3 PdOut, 4 PdIn.
    pub usage: u8,
}

/// A PDO entry of categories 50/51.
#[derive(Clone, Copy, Debug)]
pub struct SiiPdoEntry {
    /// Object index.
    pub index: u16,
    /// Subindex.
    pub subindex: u8,
    /// Data type (CoE code, e.g. 0x03 INTEGER16).
    pub data_type: u8,
    /// Bit length.
    pub bits: u8,
}

/// A PDO of categories 50 (TxPDO) / 51 (RxPDO).
#[derive(Clone, Debug)]
pub struct SiiPdo {
    /// PDO index (0x1600 / 0x1A00 ...).
    pub index: u16,
    /// SyncManager it is assigned to.
    pub sm: u8,
    /// Entries.
    pub entries: Vec<SiiPdoEntry>,
}

/// Builder of an SII image.
#[derive(Clone, Debug)]
pub struct SiiBuilder {
    config: [u16; 7],
    identity: [u32; 4],
    mailbox: [u16; 4],
    protocols: u16,
    strings: Vec<String>,
    general: Option<[u8; 32]>,
    fmmus: Vec<u8>,
    sms: Vec<SiiSyncManager>,
    txpdos: Vec<SiiPdo>,
    rxpdos: Vec<SiiPdo>,
    size_bytes: usize,
}

impl Default for SiiBuilder {
    fn default() -> Self {
        Self::new()
    }
}

impl SiiBuilder {
    /// The board's configuration words (SPI PDI 0x0E05, mode 3 + SYNC0 push-pull active
    /// high 0x0603, SYNC pulse 1 us) and an empty device; a 2 KB (16 Kbit) image.
    pub fn new() -> Self {
        Self {
            config: [0x0E05, 0x0603, 0x0064, 0, 0, 0, 0],
            identity: [0, 0, 0, 0],
            mailbox: [0; 4],
            protocols: 0,
            strings: Vec::new(),
            general: None,
            fmmus: Vec::new(),
            sms: Vec::new(),
            txpdos: Vec::new(),
            rxpdos: Vec::new(),
            size_bytes: 2048,
        }
    }

    /// Sets configuration word `i` (0..=6).
    pub fn config_word(mut self, i: usize, v: u16) -> Self {
        self.config[i] = v;
        self
    }

    /// Vendor, product code, revision, serial (words 8..15).
    pub fn identity(mut self, vendor: u32, product: u32, revision: u32, serial: u32) -> Self {
        self.identity = [vendor, product, revision, serial];
        self
    }

    /// Standard mailbox (words 0x18..0x1C).
    pub fn mailbox(mut self, rx: (u16, u16), tx: (u16, u16), protocols: u16) -> Self {
        self.mailbox = [rx.0, rx.1, tx.0, tx.1];
        self.protocols = protocols;
        self
    }

    /// Adds a string (category 10); returns its 1-based index through `idx`.
    pub fn string(mut self, s: &str, idx: &mut u8) -> Self {
        self.strings.push(s.to_string());
        *idx = self.strings.len() as u8;
        self
    }

    /// General category with the given order/name string index (used for both; masters
    /// such as ethercrab show the order string as the device name) and CoE details byte.
    pub fn general(mut self, name_idx: u8, coe_details: u8) -> Self {
        let mut g = [0u8; 32];
        g[2] = name_idx;
        g[3] = name_idx;
        g[5] = coe_details;
        // Ports 0 and 1 MII (bytes 16..17 per ETG.2010; 14..15 left 0).
        g[16] = 0x11;
        self.general = Some(g);
        self
    }

    /// FMMU usage list (category 40): 1 outputs, 2 inputs, 3 SM status.
    pub fn fmmus(mut self, usage: &[u8]) -> Self {
        self.fmmus = usage.to_vec();
        self
    }

    /// Adds a SyncManager (category 41, index = order of calls).
    pub fn sync_manager(mut self, sm: SiiSyncManager) -> Self {
        self.sms.push(sm);
        self
    }

    /// Adds a TxPDO (inputs, category 50).
    pub fn txpdo(mut self, pdo: SiiPdo) -> Self {
        self.txpdos.push(pdo);
        self
    }

    /// Adds an RxPDO (outputs, category 51).
    pub fn rxpdo(mut self, pdo: SiiPdo) -> Self {
        self.rxpdos.push(pdo);
        self
    }

    fn category(out: &mut Vec<u8>, ty: u16, mut data: Vec<u8>) {
        if data.len() % 2 != 0 {
            data.push(0);
        }
        out.extend_from_slice(&ty.to_le_bytes());
        out.extend_from_slice(&((data.len() / 2) as u16).to_le_bytes());
        out.extend_from_slice(&data);
    }

    fn pdo_bytes(pdos: &[SiiPdo]) -> Vec<u8> {
        let mut d = Vec::new();
        for p in pdos {
            d.extend_from_slice(&p.index.to_le_bytes());
            d.push(p.entries.len() as u8);
            d.push(p.sm);
            d.extend_from_slice(&[0, 0, 0, 0]); // DC sync, name, flags
            for e in &p.entries {
                d.extend_from_slice(&e.index.to_le_bytes());
                d.push(e.subindex);
                d.push(0); // name
                d.push(e.data_type);
                d.push(e.bits);
                d.extend_from_slice(&[0, 0]);
            }
        }
        d
    }

    /// The image (CRC of word 7 filled in, padded with 0xFF).
    pub fn build(&self) -> Vec<u8> {
        let mut out = Vec::with_capacity(self.size_bytes);
        for w in self.config {
            out.extend_from_slice(&w.to_le_bytes());
        }
        let crc = sii_crc8(&out[..14]);
        out.extend_from_slice(&[crc, 0]);
        for v in self.identity {
            out.extend_from_slice(&v.to_le_bytes());
        }
        out.resize(0x14 * 2, 0);
        out.resize(0x18 * 2, 0); // bootstrap mailbox: none
        for w in self.mailbox {
            out.extend_from_slice(&w.to_le_bytes());
        }
        out.extend_from_slice(&self.protocols.to_le_bytes());
        out.resize(0x3E * 2, 0);
        let kbit = (self.size_bytes * 8 / 1024) as u16;
        out.extend_from_slice(&(kbit - 1).to_le_bytes());
        out.extend_from_slice(&1u16.to_le_bytes());
        if !self.strings.is_empty() {
            let mut d = vec![self.strings.len() as u8];
            for s in &self.strings {
                d.push(s.len() as u8);
                d.extend_from_slice(s.as_bytes());
            }
            Self::category(&mut out, 10, d);
        }
        if let Some(g) = self.general {
            Self::category(&mut out, 30, g.to_vec());
        }
        if !self.fmmus.is_empty() {
            Self::category(&mut out, 40, self.fmmus.clone());
        }
        if !self.sms.is_empty() {
            let mut d = Vec::new();
            for s in &self.sms {
                d.extend_from_slice(&s.start.to_le_bytes());
                d.extend_from_slice(&s.len.to_le_bytes());
                d.extend_from_slice(&[s.control, 0, s.enable, s.usage]);
            }
            Self::category(&mut out, 41, d);
        }
        if !self.txpdos.is_empty() {
            Self::category(&mut out, 50, Self::pdo_bytes(&self.txpdos));
        }
        if !self.rxpdos.is_empty() {
            Self::category(&mut out, 51, Self::pdo_bytes(&self.rxpdos));
        }
        out.extend_from_slice(&[0xFF, 0xFF]);
        out.resize(self.size_bytes.max(out.len()), 0xFF);
        out
    }
}

/// The test device used by the system tests: no mailbox, one RxPDO 0x1600 with
/// 0x7000:01 (16 bit) on SM2 at 0x1100 and one TxPDO 0x1A00 with 0x6000:01 (16 bit) on
/// SM3 at 0x1180. Placeholder identity (vendor 0 is not a real ETG vendor ID).
pub fn minimal_io_device() -> Vec<u8> {
    let mut name = 0;
    SiiBuilder::new()
        .identity(0, 0x0000_1234, 1, 42)
        .string("Virtual analog IO", &mut name)
        .general(name, 0)
        .fmmus(&[1, 2, 1, 2])
        .sync_manager(SiiSyncManager {
            start: 0x1000,
            len: 0x80,
            control: 0x26,
            enable: 0x01,
            usage: 1,
        })
        .sync_manager(SiiSyncManager {
            start: 0x1080,
            len: 0x80,
            control: 0x22,
            enable: 0x01,
            usage: 2,
        })
        .sync_manager(SiiSyncManager {
            start: 0x1100,
            len: 2,
            control: 0x64,
            enable: 0x01,
            usage: 3,
        })
        .sync_manager(SiiSyncManager {
            start: 0x1180,
            len: 2,
            control: 0x20,
            enable: 0x01,
            usage: 4,
        })
        .rxpdo(SiiPdo {
            index: 0x1600,
            sm: 2,
            entries: vec![SiiPdoEntry {
                index: 0x7000,
                subindex: 1,
                data_type: 0x03,
                bits: 16,
            }],
        })
        .txpdo(SiiPdo {
            index: 0x1A00,
            sm: 3,
            entries: vec![SiiPdoEntry {
                index: 0x6000,
                subindex: 1,
                data_type: 0x03,
                bits: 16,
            }],
        })
        .build()
}
