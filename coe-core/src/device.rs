//! The device description: one constant value from which the firmware's tables, the SII
//! EEPROM image ([`crate::sii`]) and the ESI XML are derived, so the three cannot disagree.
//!
//! It holds what is not already in the object dictionary (identity, names, SyncManager and
//! FMMU layout, mailbox protocols, DC op modes, PDI configuration, EEPROM size) and a
//! reference to the dictionary. The default PDO assignment and mappings are *not* stored
//! twice: they are the defaults of 0x1C12/0x1C13 and 0x16xx/0x1Axx in the dictionary, read
//! through [`DeviceDescription::assigned_pdos`] and [`DeviceDescription::pdo_entries`].
//!
//! [`DeviceDescription::validate`] is a `const fn`, so a bad description stops the build:
//!
//! ```ignore
//! const _: () = if let Err(e) = DEVICE.validate() { panic!("{}", e.message()) };
//! ```

pub mod oversampling;

use crate::od::{EntryDesc, ObjectDesc, ObjectDictionary, OdErrorKind, Value};
use crate::pdo::{PdoDirection, PdoEntry};
use crate::sdo_server::MIN_MAILBOX;
use core::fmt;

/// The identity (0x1018, SII words 0x08..0x0F, ESI `Type` attributes).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Identity {
    /// Vendor ID (ETG-assigned).
    pub vendor_id: u32,
    /// Product code.
    pub product_code: u32,
    /// Revision number.
    pub revision: u32,
    /// Serial number written into the SII image by default (a production tool may patch it).
    pub serial_number: u32,
}

/// The names and version strings.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Names {
    /// Vendor name (ESI `Vendor/Name`).
    pub vendor_name: &'static str,
    /// Device name (0x1008, SII General name, ESI `Device/Name`).
    pub device_name: &'static str,
    /// Order code / type (SII General order string, ESI `Device/Type` text).
    pub order_code: &'static str,
    /// Group type (SII General group string, ESI `Group/Type`).
    pub group_type: &'static str,
    /// Group name (ESI `Group/Name`).
    pub group_name: &'static str,
    /// Hardware version (0x1009).
    pub hardware_version: &'static str,
    /// Software version (0x100A).
    pub software_version: &'static str,
}

/// What a SyncManager is used for (SII SyncM "type" byte, ESI `Sm` text).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum SmRole {
    /// Mailbox master -> slave (SII type 1, ESI `MBoxOut`).
    MailboxOut,
    /// Mailbox slave -> master (SII type 2, ESI `MBoxIn`).
    MailboxIn,
    /// Process data outputs (SII type 3, ESI `Outputs`).
    ProcessDataOut,
    /// Process data inputs (SII type 4, ESI `Inputs`).
    ProcessDataIn,
}

impl SmRole {
    /// The SII SyncM category type byte (ETG.2010 table 9).
    pub const fn sii_type(self) -> u8 {
        match self {
            Self::MailboxOut => 1,
            Self::MailboxIn => 2,
            Self::ProcessDataOut => 3,
            Self::ProcessDataIn => 4,
        }
    }

    /// The role of an SII SyncM category type byte (`None`: 0 = unused, or unknown).
    pub const fn from_sii_type(code: u8) -> Option<Self> {
        match code {
            1 => Some(Self::MailboxOut),
            2 => Some(Self::MailboxIn),
            3 => Some(Self::ProcessDataOut),
            4 => Some(Self::ProcessDataIn),
            _ => None,
        }
    }

    /// The ESI `Sm` element text.
    pub const fn esi_name(self) -> &'static str {
        match self {
            Self::MailboxOut => "MBoxOut",
            Self::MailboxIn => "MBoxIn",
            Self::ProcessDataOut => "Outputs",
            Self::ProcessDataIn => "Inputs",
        }
    }

    /// True for the two mailbox roles.
    pub const fn is_mailbox(self) -> bool {
        matches!(self, Self::MailboxOut | Self::MailboxIn)
    }

    /// True if the master writes the buffer (mailbox out, outputs).
    pub const fn master_writes(self) -> bool {
        matches!(self, Self::MailboxOut | Self::ProcessDataOut)
    }

    /// The PDO direction of a process-data role.
    pub const fn pdo_direction(self) -> Option<PdoDirection> {
        match self {
            Self::ProcessDataOut => Some(PdoDirection::Rx),
            Self::ProcessDataIn => Some(PdoDirection::Tx),
            _ => None,
        }
    }

    const fn bit(self) -> u8 {
        1 << (self.sii_type() - 1)
    }
}

/// One SyncManager (ESC register 0x0800 + 8n, ETG.1000.4 / ESC datasheet section II).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct SyncManagerDesc {
    /// Physical start address in the ESC RAM.
    pub start: u16,
    /// Mailbox: the mailbox size. Process data: the room reserved for one buffer (the
    /// largest image the PDO configuration may produce); a buffered SM occupies three times
    /// this length. The SII/ESI default length of a process-data SM is the size of the
    /// default PDOs ([`DeviceDescription::default_sm_len`]).
    pub len: u16,
    /// Control byte (register +4): b1:0 mode (00 buffered, 10 mailbox), b3:2 direction
    /// (00 ECAT reads, 01 ECAT writes), b4 ECAT IRQ, b5 PDI IRQ, b6 watchdog.
    pub control: u8,
    /// Enabled by default (SII enable byte b0, ESI `Enable`).
    pub enable: bool,
    /// What it is used for.
    pub role: SmRole,
}

/// Control byte bits of a SyncManager (ESC register 0x0804 + 8n, SII SyncManager category
/// byte 4, ESI `Sm/@ControlByte`; ETG.1000.4, ESC datasheet section II 2.14).
///
/// The one definition of these fields: they describe the device (SII, ESI, the checks of
/// [`DeviceDescription::validate`]) as much as the ESC register, and this crate stays free of
/// any ESC chip, so ESC drivers (the `et1100` crate's `SyncManager`) read them from here.
pub mod sm_control {
    /// Mode field mask (b1:0).
    pub const MODE_MASK: u8 = 0x03;
    /// Buffered (three buffers) mode.
    pub const MODE_BUFFERED: u8 = 0x00;
    /// Mailbox (one buffer) mode.
    pub const MODE_MAILBOX: u8 = 0x02;
    /// Direction field mask (b3:2).
    pub const DIR_MASK: u8 = 0x0C;
    /// ECAT reads, PDI writes.
    pub const DIR_ECAT_READ: u8 = 0x00;
    /// ECAT writes, PDI reads.
    pub const DIR_ECAT_WRITE: u8 = 0x04;
    /// Interrupt in the ECAT event request register.
    pub const ECAT_IRQ: u8 = 0x10;
    /// Interrupt in the AL event request register (PDI).
    pub const PDI_IRQ: u8 = 0x20;
    /// Watchdog trigger enable.
    pub const WATCHDOG: u8 = 0x40;
}

impl SyncManagerDesc {
    /// A SyncManager, enabled by default.
    pub const fn new(role: SmRole, start: u16, len: u16, control: u8) -> Self {
        Self {
            start,
            len,
            control,
            enable: true,
            role,
        }
    }

    /// True if the control byte selects buffered (three-buffer) mode.
    pub const fn is_buffered(&self) -> bool {
        self.control & sm_control::MODE_MASK == sm_control::MODE_BUFFERED
    }

    /// Bytes of ESC RAM the SyncManager occupies (three buffers in buffered mode).
    pub const fn occupied_len(&self) -> u32 {
        if self.is_buffered() {
            3 * self.len as u32
        } else {
            self.len as u32
        }
    }

    /// True if mode and direction bits of the control byte fit the role.
    pub const fn control_fits_role(&self) -> bool {
        let mode = if self.role.is_mailbox() {
            sm_control::MODE_MAILBOX
        } else {
            sm_control::MODE_BUFFERED
        };
        let dir = if self.role.master_writes() {
            sm_control::DIR_ECAT_WRITE
        } else {
            sm_control::DIR_ECAT_READ
        };
        self.control & sm_control::MODE_MASK == mode && self.control & sm_control::DIR_MASK == dir
    }
}

/// What an FMMU is used for (SII FMMU category byte, ESI `Fmmu` text).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum FmmuUsage {
    /// Not used (0).
    Unused,
    /// Process data outputs (1, ESI `Outputs`).
    Outputs,
    /// Process data inputs (2, ESI `Inputs`).
    Inputs,
    /// Mailbox state: SyncManager status (3, ESI `MBoxState`).
    MailboxState,
}

impl FmmuUsage {
    /// The SII FMMU category byte.
    pub const fn sii_code(self) -> u8 {
        match self {
            Self::Unused => 0,
            Self::Outputs => 1,
            Self::Inputs => 2,
            Self::MailboxState => 3,
        }
    }

    /// The ESI `Fmmu` element text (`None` for unused).
    pub const fn esi_name(self) -> Option<&'static str> {
        match self {
            Self::Unused => None,
            Self::Outputs => Some("Outputs"),
            Self::Inputs => Some("Inputs"),
            Self::MailboxState => Some("MBoxState"),
        }
    }
}

/// Mailbox protocols, with the bit layout of SII word 0x1C.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct MailboxProtocols(pub u16);

impl MailboxProtocols {
    /// ADS over EtherCAT.
    pub const AOE: u16 = 0x0001;
    /// Ethernet over EtherCAT.
    pub const EOE: u16 = 0x0002;
    /// CANopen over EtherCAT.
    pub const COE: u16 = 0x0004;
    /// File access over EtherCAT.
    pub const FOE: u16 = 0x0008;
    /// Servo profile over EtherCAT.
    pub const SOE: u16 = 0x0010;
    /// Vendor-specific.
    pub const VOE: u16 = 0x0020;

    /// The SII word.
    pub const fn bits(self) -> u16 {
        self.0
    }

    /// True if CoE is supported.
    pub const fn coe(self) -> bool {
        self.0 & Self::COE != 0
    }

    /// True if FoE is supported.
    pub const fn foe(self) -> bool {
        self.0 & Self::FOE != 0
    }

    /// True if any protocol is supported (the device needs mailbox SyncManagers).
    pub const fn any(self) -> bool {
        self.0 != 0
    }
}

/// CoE details, with the bit layout of the SII General category byte 5 (ETG.2010).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct CoeDetails(pub u8);

impl CoeDetails {
    /// SDO services.
    pub const SDO: u8 = 0x01;
    /// SDO Information.
    pub const SDO_INFO: u8 = 0x02;
    /// PDO assignment (0x1C12/0x1C13) writable.
    pub const PDO_ASSIGN: u8 = 0x04;
    /// PDO configuration (0x16xx/0x1Axx) writable.
    pub const PDO_CONFIG: u8 = 0x08;
    /// PDO configuration is uploaded by the master at startup.
    pub const UPLOAD_AT_STARTUP: u8 = 0x10;
    /// SDO complete access.
    pub const COMPLETE_ACCESS: u8 = 0x20;

    /// The SII byte.
    pub const fn bits(self) -> u8 {
        self.0
    }

    /// SDO supported.
    pub const fn sdo(self) -> bool {
        self.0 & Self::SDO != 0
    }

    /// SDO Information supported.
    pub const fn sdo_info(self) -> bool {
        self.0 & Self::SDO_INFO != 0
    }

    /// PDO assignment configurable.
    pub const fn pdo_assign(self) -> bool {
        self.0 & Self::PDO_ASSIGN != 0
    }

    /// PDO mapping configurable.
    pub const fn pdo_config(self) -> bool {
        self.0 & Self::PDO_CONFIG != 0
    }

    /// PDO configuration uploaded at startup.
    pub const fn upload_at_startup(self) -> bool {
        self.0 & Self::UPLOAD_AT_STARTUP != 0
    }

    /// Complete access supported.
    pub const fn complete_access(self) -> bool {
        self.0 & Self::COMPLETE_ACCESS != 0
    }
}

/// A mailbox window of the bootstrap state (SII words 0x14..0x17).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct MemoryWindow {
    /// Start address.
    pub start: u16,
    /// Length in bytes.
    pub len: u16,
}

impl MemoryWindow {
    /// A window.
    pub const fn new(start: u16, len: u16) -> Self {
        Self { start, len }
    }

    /// One past the last address.
    pub const fn end(&self) -> u32 {
        self.start as u32 + self.len as u32
    }
}

/// The mailbox: protocols and CoE details (the windows are SM0/SM1).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct MailboxDesc {
    /// Supported protocols.
    pub protocols: MailboxProtocols,
    /// CoE services.
    pub coe: CoeDetails,
    /// Bootstrap mailbox (out = master -> slave, in = slave -> master), if the device has
    /// a BOOT state: the windows SM0/SM1 get in BOOT (SII words 0x14..0x17, ESI
    /// `Eeprom/BootStrap`); FoE only.
    pub bootstrap: Option<(MemoryWindow, MemoryWindow)>,
}

/// One synchronisation mode (ESI `Dc/OpMode`, SII DC category entry).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct DcOpMode {
    /// Short name (ESI `Name`).
    pub name: &'static str,
    /// Description (ESI `Desc`).
    pub description: &'static str,
    /// Value for ESC registers 0x0980/0x0981 (0x0300 = SYNC0 cyclic, 0 = DC unused).
    pub assign_activate: u16,
    /// The 0x1C32:01 sync mode this op mode selects (0 free run, 1 SM-synchronous,
    /// 2 DC SYNC0).
    pub sync_mode: u16,
    /// SYNC0 cycle time in ns (0 = the master's bus cycle).
    pub cycle_time_sync0: u32,
    /// SYNC0 cycle time factor (ESI `CycleTimeSync0 Factor`).
    pub sync0_factor: i16,
    /// SYNC0 shift time in ns.
    pub shift_time_sync0: u32,
    /// SYNC1 cycle time factor (0 = SYNC1 unused).
    pub sync1_factor: i16,
    /// SYNC1 shift time in ns.
    pub shift_time_sync1: u32,
}

/// Distributed clocks and synchronisation.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct DcDesc {
    /// The op modes the device supports, the default first.
    pub op_modes: &'static [DcOpMode],
    /// Shortest cycle time in ns (0x1C32:05).
    pub min_cycle_ns: u32,
    /// Longest cycle time in ns.
    pub max_cycle_ns: u32,
}

/// Driver and polarity of an ESC output pin (SPI_IRQ, SYNC0/1; registers 0x0150/0x0151).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum PinDriver {
    /// Push-pull, active low (00).
    PushPullActiveLow,
    /// Open drain, active low (01).
    OpenDrainActiveLow,
    /// Push-pull, active high (10).
    PushPullActiveHigh,
    /// Open source, active high (11).
    OpenSourceActiveHigh,
}

impl PinDriver {
    /// The two-bit register code.
    pub const fn code(self) -> u8 {
        match self {
            Self::PushPullActiveLow => 0b00,
            Self::OpenDrainActiveLow => 0b01,
            Self::PushPullActiveHigh => 0b10,
            Self::OpenSourceActiveHigh => 0b11,
        }
    }
}

/// Configuration of a SYNC/LATCH pin (register 0x0151, one nibble per pin).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct SyncPin {
    /// Output driver and polarity.
    pub driver: PinDriver,
    /// True: the pin is a SYNC output; false: a LATCH input.
    pub output: bool,
    /// Also signal the SYNC event in the AL event register (0x0220 b2/b3).
    pub to_al_event: bool,
}

impl SyncPin {
    /// The register nibble.
    pub const fn nibble(self) -> u8 {
        self.driver.code() | (self.output as u8) << 2 | (self.to_al_event as u8) << 3
    }
}

/// PDI type code of an SPI slave (register 0x0140).
pub const PDI_SPI_SLAVE: u8 = 0x05;

/// PDI type code of the 16-bit asynchronous µC interface (register 0x0140).
pub const PDI_ASYNC_UC_16BIT: u8 = 0x08;

/// The process data interface and its own bits of 0x0150 (the rest of the PDI
/// configuration is common to both).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum PdiInterface {
    /// SPI slave ([`PDI_SPI_SLAVE`]).
    Spi {
        /// SPI mode 0..3 (0x0150 b1:0).
        mode: u8,
        /// SPI_SEL active high (0x0150 b4).
        sel_active_high: bool,
        /// Late MISO sampling (0x0150 b5).
        miso_late_sample: bool,
    },
    /// 16-bit asynchronous µC interface ([`PDI_ASYNC_UC_16BIT`]).
    AsyncUc16 {
        /// BUSY driver and polarity (0x0150 b1:0).
        busy: PinDriver,
        /// BHE active high (0x0150 b4).
        bhe_active_high: bool,
        /// RD active high (0x0150 b7).
        rd_active_high: bool,
    },
}

impl PdiInterface {
    /// The PDI type code (0x0140).
    pub const fn pdi_type(&self) -> u8 {
        match self {
            Self::Spi { .. } => PDI_SPI_SLAVE,
            Self::AsyncUc16 { .. } => PDI_ASYNC_UC_16BIT,
        }
    }

    /// The interface's bits of 0x0150 (the IRQ driver, b3:2, is common).
    pub const fn config_bits(&self) -> u8 {
        match *self {
            Self::Spi {
                mode,
                sel_active_high,
                miso_late_sample,
            } => (mode & 0x03) | (sel_active_high as u8) << 4 | (miso_late_sample as u8) << 5,
            Self::AsyncUc16 {
                busy,
                bhe_active_high,
                rd_active_high,
            } => busy.code() | (bhe_active_high as u8) << 4 | (rd_active_high as u8) << 7,
        }
    }
}

/// The PDI configuration the ESC loads from SII words 0..3 (ESC registers 0x0140/0x0141,
/// 0x0150/0x0151, 0x0982, 0x0152).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct PdiConfig {
    /// The interface (0x0140 and its bits of 0x0150).
    pub interface: PdiInterface,
    /// 0x0141 b1: enhanced link detection.
    pub enhanced_link_detect: bool,
    /// 0x0141 b2: DC SYNC output unit enabled.
    pub dc_sync_unit: bool,
    /// 0x0141 b3: DC latch input unit enabled.
    pub dc_latch_unit: bool,
    /// IRQ (SPI_IRQ) driver and polarity (0x0150 b3:2).
    pub irq: PinDriver,
    /// SYNC0/LATCH0 pin (0x0151 b3:0).
    pub sync0: SyncPin,
    /// SYNC1/LATCH1 pin (0x0151 b7:4).
    pub sync1: SyncPin,
    /// SYNC impulse length in units of 10 ns (0x0982; 0 = acknowledge mode).
    pub sync_pulse_10ns: u16,
    /// Extended PDI configuration (0x0152, SII word 3).
    pub extended: u16,
}

impl PdiConfig {
    /// SII word 0: PDI control (0x0140) and ESC configuration (0x0141).
    pub const fn word0(&self) -> u16 {
        let esc_config = (self.enhanced_link_detect as u8) << 1
            | (self.dc_sync_unit as u8) << 2
            | (self.dc_latch_unit as u8) << 3;
        u16::from_le_bytes([self.interface.pdi_type(), esc_config])
    }

    /// SII word 1: PDI configuration (0x0150) and SYNC/LATCH configuration (0x0151).
    pub const fn word1(&self) -> u16 {
        let pdi = self.interface.config_bits() | self.irq.code() << 2;
        let sync = self.sync0.nibble() | self.sync1.nibble() << 4;
        u16::from_le_bytes([pdi, sync])
    }
}

/// The SII EEPROM.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct EepromDesc {
    /// Size in bytes (a multiple of 128 bytes = 1 Kbit, at least 256 bytes).
    pub size_bytes: u32,
    /// Configured station alias (SII word 4).
    pub station_alias: u16,
    /// SII version (word 0x3F; 1 per ETG.2010).
    pub version: u16,
}

impl EepromDesc {
    /// SII word 0x3E: size in Kbit minus one.
    pub const fn size_word(&self) -> u16 {
        (self.size_bytes / 128).saturating_sub(1) as u16
    }
}

/// Physical port type (SII General category bytes 16..17, one nibble per port).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum PortType {
    /// Not used.
    None,
    /// MII (Ethernet PHY).
    Mii,
    /// Reserved code 2.
    Reserved,
    /// E-Bus (LVDS).
    Ebus,
}

impl PortType {
    /// The nibble.
    pub const fn code(self) -> u8 {
        match self {
            Self::None => 0,
            Self::Mii => 1,
            Self::Reserved => 2,
            Self::Ebus => 3,
        }
    }

    /// The ESI `Physics` letter (`Y` MII, `K` E-Bus, space for none).
    pub const fn esi_letter(self) -> char {
        match self {
            Self::Mii => 'Y',
            Self::Ebus => 'K',
            Self::None | Self::Reserved => ' ',
        }
    }
}

/// The whole description of a device.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct DeviceDescription {
    /// Identity (must equal the defaults of 0x1018).
    pub identity: Identity,
    /// Names (the device name and versions must equal 0x1008..0x100A where present).
    pub names: Names,
    /// The object dictionary, including the default PDO assignment and mappings.
    pub od: &'static ObjectDictionary,
    /// SyncManagers in SM order (SM0, SM1, ...).
    pub sync_managers: &'static [SyncManagerDesc],
    /// FMMUs in FMMU order.
    pub fmmus: &'static [FmmuUsage],
    /// Mailbox protocols and CoE details.
    pub mailbox: MailboxDesc,
    /// Synchronisation modes.
    pub dc: DcDesc,
    /// PDI configuration (SII words 0..3).
    pub pdi: PdiConfig,
    /// EEPROM size, alias, version.
    pub eeprom: EepromDesc,
    /// The ESC's process RAM (ET1100: 0x1000, 8 KB); every SyncManager must lie inside.
    pub process_ram: MemoryWindow,
    /// Physical ports 0..3.
    pub ports: [PortType; 4],
    /// Current drawn from the E-Bus in mA (negative: fed into it); 0 for MII devices.
    pub ebus_current_ma: i16,
}

/// Index of the identity object.
pub const IDENTITY_INDEX: u16 = 0x1018;
/// Index of the device name object.
pub const DEVICE_NAME_INDEX: u16 = 0x1008;
/// Index of the hardware version object.
pub const HARDWARE_VERSION_INDEX: u16 = 0x1009;
/// Index of the software version object.
pub const SOFTWARE_VERSION_INDEX: u16 = 0x100A;

/// The assignment object of a direction (0x1C12 Rx, 0x1C13 Tx).
pub const fn assignment_index(direction: PdoDirection) -> u16 {
    match direction {
        PdoDirection::Rx => 0x1C12,
        PdoDirection::Tx => 0x1C13,
    }
}

impl DeviceDescription {
    /// The SyncManager with this role and its number.
    pub const fn sync_manager(&self, role: SmRole) -> Option<(u8, &'static SyncManagerDesc)> {
        let sms: &'static [SyncManagerDesc] = self.sync_managers;
        let mut i = 0;
        while i < sms.len() {
            if sms[i].role as u8 == role as u8 {
                return Some((i as u8, &sms[i]));
            }
            i += 1;
        }
        None
    }

    /// The process-data SyncManager of a PDO direction and its number.
    pub const fn pdo_sync_manager(
        &self,
        direction: PdoDirection,
    ) -> Option<(u8, &'static SyncManagerDesc)> {
        self.sync_manager(match direction {
            PdoDirection::Rx => SmRole::ProcessDataOut,
            PdoDirection::Tx => SmRole::ProcessDataIn,
        })
    }

    /// The PDO mapping objects (0x16xx or 0x1Axx) the dictionary offers, in index order.
    pub fn pdo_objects(
        &self,
        direction: PdoDirection,
    ) -> impl Iterator<Item = &'static ObjectDesc> + 'static {
        let objects: &'static [ObjectDesc] = self.od.objects;
        objects.iter().filter(
            move |o| matches!(PdoDirection::of_mapping_index(o.index), Some(d) if d == direction),
        )
    }

    /// The default PDO assignment of a direction: the defaults of 0x1C12/0x1C13 sub
    /// 1..=sub 0 (empty if the object is absent).
    pub fn assigned_pdos(&self, direction: PdoDirection) -> DefaultValues {
        DefaultValues::of(find_object(self.od, assignment_index(direction)))
    }

    /// The default mapping of a PDO: the defaults of its sub 1..=sub 0 as [`PdoEntry`]s
    /// (empty if the object is absent).
    pub fn pdo_entries(&self, pdo_index: u16) -> impl Iterator<Item = PdoEntry> {
        DefaultValues::of(find_object(self.od, pdo_index)).map(PdoEntry::from_u32)
    }

    /// True if the PDO's mapping cannot be changed (its sub 0 is not writable).
    pub fn pdo_is_fixed(&self, pdo_index: u16) -> bool {
        match find_object(self.od, pdo_index) {
            Some(ObjectDesc {
                entries: [sub0, ..],
                ..
            }) => !sub0.access.is_writable(),
            _ => true,
        }
    }

    /// Bits of the default process image of a direction (the assigned PDOs' entries).
    pub const fn default_pdo_bits(&self, direction: PdoDirection) -> u32 {
        let assign = find_object(self.od, assignment_index(direction));
        let n = default_count(assign);
        let mut bits = 0u32;
        let mut sub = 1;
        while sub <= n {
            if let Some(pdo) = default_u32(assign, sub) {
                let mapping = find_object(self.od, pdo as u16);
                let m = default_count(mapping);
                let mut e = 1;
                while e <= m {
                    if let Some(raw) = default_u32(mapping, e) {
                        bits += PdoEntry::from_u32(raw).bit_len as u32;
                    }
                    e += 1;
                }
            }
            sub += 1;
        }
        bits
    }

    /// Default length of a SyncManager as the SII/ESI give it: the mailbox size, or the
    /// bytes of the default PDOs of a process-data SM.
    pub const fn default_sm_len(&self, sm: &SyncManagerDesc) -> u16 {
        match sm.role.pdo_direction() {
            Some(d) => self.default_pdo_bits(d).div_ceil(8) as u16,
            None => sm.len,
        }
    }

    /// The SyncManager a PDO belongs to by default: the process-data SM of its direction.
    pub const fn sm_of_pdo(&self, pdo_index: u16) -> Option<u8> {
        match PdoDirection::of_mapping_index(pdo_index) {
            Some(d) => match self.pdo_sync_manager(d) {
                Some((n, _)) => Some(n),
                None => None,
            },
            None => None,
        }
    }

    /// True if the PDO is in the default assignment.
    pub fn pdo_is_assigned(&self, pdo_index: u16) -> bool {
        match PdoDirection::of_mapping_index(pdo_index) {
            Some(d) => self.assigned_pdos(d).any(|p| p as u16 == pdo_index),
            None => false,
        }
    }

    /// The dictionary entry a mapping entry points at (`None` for gaps and unknown entries).
    pub fn mapped_entry(&self, entry: PdoEntry) -> Option<&'static EntryDesc> {
        if entry.is_gap() {
            return None;
        }
        self.od
            .entry(entry.index, entry.subindex)
            .ok()
            .map(|(_, e)| e)
    }

    /// Checks the description; usable in a `const` item. Rejected (in this order): an
    /// invalid dictionary (see [`ObjectDictionary::validate`]); empty names; identity,
    /// device name or versions differing from 0x1018/0x1008..0x100A (0x1018 is required);
    /// SyncManager problems (a role twice, control byte not fitting the role, outside the
    /// process RAM, overlapping, mailbox smaller than [`MIN_MAILBOX`], protocols without
    /// mailbox SMs); a bad bootstrap mailbox (outside the process RAM, too small,
    /// overlapping itself, without FoE); PDO problems (mapping objects whose defaults map a missing entry, an
    /// entry not mappable at all or only in the other direction, a wrong bit length, a
    /// count above the entries; an assignment naming a missing PDO or one of the other
    /// direction; a default image larger than its SM or without SM/FMMU); DC cycle limits
    /// (min > max or min 0) and EEPROM size.
    pub const fn validate(&self) -> Result<(), DescError> {
        if let Err(e) = self.od.validate() {
            return Err(DescError::new(
                DescErrorKind::Dictionary(e.kind),
                e.index,
                e.subindex,
            ));
        }
        if let Err(e) = self.validate_names() {
            return Err(e);
        }
        if let Err(e) = self.validate_sync_managers() {
            return Err(e);
        }
        if let Err(e) = self.validate_bootstrap() {
            return Err(e);
        }
        if let Err(e) = self.validate_pdos(PdoDirection::Rx) {
            return Err(e);
        }
        if let Err(e) = self.validate_pdos(PdoDirection::Tx) {
            return Err(e);
        }
        if self.dc.min_cycle_ns == 0 || self.dc.min_cycle_ns > self.dc.max_cycle_ns {
            return Err(DescError::new(DescErrorKind::BadCycleLimits, 0, 0));
        }
        let size = self.eeprom.size_bytes;
        if size < 256 || size % 128 != 0 || size > 128 * 0x1_0000 {
            return Err(DescError::new(DescErrorKind::BadEepromSize, 0, 0));
        }
        Ok(())
    }

    const fn validate_names(&self) -> Result<(), DescError> {
        let n = &self.names;
        if n.vendor_name.is_empty()
            || n.device_name.is_empty()
            || n.order_code.is_empty()
            || n.group_type.is_empty()
            || n.group_name.is_empty()
        {
            return Err(DescError::new(DescErrorKind::EmptyName, 0, 0));
        }
        let identity = match find_object(self.od, IDENTITY_INDEX) {
            Some(o) => o,
            None => {
                return Err(DescError::new(
                    DescErrorKind::MissingIdentity,
                    IDENTITY_INDEX,
                    0,
                ))
            }
        };
        let id = &self.identity;
        let expected = [id.vendor_id, id.product_code, id.revision, id.serial_number];
        let mut sub = 1;
        while sub <= 4 {
            match default_u32(Some(identity), sub) {
                Some(v) if v == expected[sub as usize - 1] => {}
                _ => {
                    return Err(DescError::new(
                        DescErrorKind::IdentityMismatch,
                        IDENTITY_INDEX,
                        sub,
                    ))
                }
            }
            sub += 1;
        }
        let strings = [
            (DEVICE_NAME_INDEX, n.device_name),
            (HARDWARE_VERSION_INDEX, n.hardware_version),
            (SOFTWARE_VERSION_INDEX, n.software_version),
        ];
        let mut i = 0;
        while i < strings.len() {
            let (index, text) = strings[i];
            if let Some(object) = find_object(self.od, index) {
                let same = match find_entry(object, 0) {
                    Some(entry) => match entry.default() {
                        Value::Str(s) => str_eq(s, text),
                        _ => false,
                    },
                    None => false,
                };
                if !same {
                    return Err(DescError::new(DescErrorKind::StringMismatch, index, 0));
                }
            }
            i += 1;
        }
        Ok(())
    }

    const fn validate_sync_managers(&self) -> Result<(), DescError> {
        let sms = self.sync_managers;
        let ram = &self.process_ram;
        let mut seen = 0u8;
        let mut i = 0;
        while i < sms.len() {
            let sm = &sms[i];
            let n = i as u16;
            if seen & sm.role.bit() != 0 {
                return Err(DescError::new(DescErrorKind::SmRoleTwice, n, 0));
            }
            seen |= sm.role.bit();
            if !sm.control_fits_role() {
                return Err(DescError::new(DescErrorKind::SmControlMismatch, n, 0));
            }
            if sm.start < ram.start || sm.start as u32 + sm.occupied_len() > ram.end() {
                return Err(DescError::new(DescErrorKind::SmOutsideProcessRam, n, 0));
            }
            if sm.role.is_mailbox() && (sm.len as usize) < MIN_MAILBOX {
                return Err(DescError::new(DescErrorKind::MailboxTooSmall, n, 0));
            }
            let mut j = 0;
            while j < i {
                let other = &sms[j];
                let (a0, a1) = (sm.start as u32, sm.start as u32 + sm.occupied_len());
                let (b0, b1) = (
                    other.start as u32,
                    other.start as u32 + other.occupied_len(),
                );
                if a0 < b1 && b0 < a1 {
                    return Err(DescError::new(DescErrorKind::SmOverlap, j as u16, i as u8));
                }
                j += 1;
            }
            i += 1;
        }
        let mailboxes = SmRole::MailboxOut.bit() | SmRole::MailboxIn.bit();
        let has_mailbox = seen & mailboxes == mailboxes;
        if seen & mailboxes != 0 && !has_mailbox {
            return Err(DescError::new(DescErrorKind::MailboxIncomplete, 0, 0));
        }
        if self.mailbox.protocols.any() && !has_mailbox {
            return Err(DescError::new(DescErrorKind::MailboxIncomplete, 0, 0));
        }
        Ok(())
    }

    /// The bootstrap mailbox: both windows inside the process RAM, each at least
    /// [`MIN_MAILBOX`] bytes, not overlapping each other, and FoE among the protocols (the
    /// BOOT state serves FoE only).
    const fn validate_bootstrap(&self) -> Result<(), DescError> {
        let Some((out, inp)) = self.mailbox.bootstrap else {
            return Ok(());
        };
        let bad = DescError::new(DescErrorKind::BadBootstrapMailbox, 0, 0);
        if !self.mailbox.protocols.foe() {
            return Err(bad);
        }
        let ram = &self.process_ram;
        let windows = [out, inp];
        let mut i = 0;
        while i < windows.len() {
            let w = windows[i];
            if w.start < ram.start || w.end() > ram.end() || (w.len as usize) < MIN_MAILBOX {
                return Err(bad);
            }
            i += 1;
        }
        if (out.start as u32) < inp.end() && (inp.start as u32) < out.end() {
            return Err(bad);
        }
        Ok(())
    }

    const fn validate_pdos(&self, direction: PdoDirection) -> Result<(), DescError> {
        // Every mapping object of this direction: its defaults must be mappable.
        let objects: &'static [ObjectDesc] = self.od.objects;
        let mut i = 0;
        while i < objects.len() {
            let object = &objects[i];
            if let Some(d) = PdoDirection::of_mapping_index(object.index) {
                if d as u8 == direction as u8 {
                    if let Err(e) = self.validate_mapping(object, direction) {
                        return Err(e);
                    }
                }
            }
            i += 1;
        }
        // The default assignment.
        let index = assignment_index(direction);
        let assign = find_object(self.od, index);
        let n = default_count(assign);
        if let Some(object) = assign {
            if n as usize + 1 > object.entries.len() {
                return Err(DescError::new(DescErrorKind::CountAboveEntries, index, 0));
            }
        }
        let mut sub = 1;
        while sub <= n {
            let pdo = match default_u32(assign, sub) {
                Some(p) => p,
                None => {
                    return Err(DescError::new(
                        DescErrorKind::AssignedPdoMissing,
                        index,
                        sub,
                    ))
                }
            };
            match PdoDirection::of_mapping_index(pdo as u16) {
                Some(d) if d as u8 == direction as u8 && pdo <= 0xFFFF => {}
                _ => {
                    return Err(DescError::new(
                        DescErrorKind::AssignedPdoWrongDirection,
                        index,
                        sub,
                    ))
                }
            }
            if find_object(self.od, pdo as u16).is_none() {
                return Err(DescError::new(
                    DescErrorKind::AssignedPdoMissing,
                    index,
                    sub,
                ));
            }
            sub += 1;
        }
        let bits = self.default_pdo_bits(direction);
        if bits > 0 {
            let sm = match self.pdo_sync_manager(direction) {
                Some((_, sm)) => sm,
                None => return Err(DescError::new(DescErrorKind::PdoWithoutSm, index, 0)),
            };
            if bits.div_ceil(8) > sm.len as u32 {
                return Err(DescError::new(DescErrorKind::ImageLargerThanSm, index, 0));
            }
            let usage = match direction {
                PdoDirection::Rx => FmmuUsage::Outputs,
                PdoDirection::Tx => FmmuUsage::Inputs,
            };
            let mut found = false;
            let mut f = 0;
            while f < self.fmmus.len() {
                if self.fmmus[f] as u8 == usage as u8 {
                    found = true;
                }
                f += 1;
            }
            if !found {
                return Err(DescError::new(DescErrorKind::PdoWithoutFmmu, index, 0));
            }
        }
        Ok(())
    }

    const fn validate_mapping(
        &self,
        object: &'static ObjectDesc,
        direction: PdoDirection,
    ) -> Result<(), DescError> {
        let index = object.index;
        let n = default_count(Some(object));
        if n as usize + 1 > object.entries.len() {
            return Err(DescError::new(DescErrorKind::CountAboveEntries, index, 0));
        }
        let mut sub = 1;
        while sub <= n {
            let entry = match default_u32(Some(object), sub) {
                Some(raw) => PdoEntry::from_u32(raw),
                None => {
                    return Err(DescError::new(
                        DescErrorKind::MappedEntryMissing,
                        index,
                        sub,
                    ))
                }
            };
            if let Err(kind) = self.check_mapped(entry, direction) {
                return Err(DescError::new(kind, index, sub));
            }
            sub += 1;
        }
        Ok(())
    }

    const fn check_mapped(
        &self,
        entry: PdoEntry,
        direction: PdoDirection,
    ) -> Result<(), DescErrorKind> {
        if entry.bit_len == 0 {
            return Err(DescErrorKind::MappedLengthMismatch);
        }
        if entry.index == 0 {
            return Ok(());
        }
        if entry.is_gap() {
            return if gap_bits(entry.index) == entry.bit_len {
                Ok(())
            } else {
                Err(DescErrorKind::MappedLengthMismatch)
            };
        }
        let target = match find_object(self.od, entry.index) {
            Some(o) => match find_entry(o, entry.subindex) {
                Some(e) => e,
                None => return Err(DescErrorKind::MappedEntryMissing),
            },
            None => return Err(DescErrorKind::MappedEntryMissing),
        };
        let (this_way, other_way) = match direction {
            PdoDirection::Rx => (
                target.access.is_rx_mappable(),
                target.access.is_tx_mappable(),
            ),
            PdoDirection::Tx => (
                target.access.is_tx_mappable(),
                target.access.is_rx_mappable(),
            ),
        };
        if !this_way {
            return Err(if other_way {
                DescErrorKind::MappedWrongDirection
            } else {
                DescErrorKind::MappedNotMappable
            });
        }
        if target.bit_len != entry.bit_len as u16 {
            return Err(DescErrorKind::MappedLengthMismatch);
        }
        Ok(())
    }
}

/// The object with this index (a `const` linear search; the dictionary is small).
const fn find_object(od: &'static ObjectDictionary, index: u16) -> Option<&'static ObjectDesc> {
    let objects: &'static [ObjectDesc] = od.objects;
    let mut i = 0;
    while i < objects.len() {
        if objects[i].index == index {
            return Some(&objects[i]);
        }
        i += 1;
    }
    None
}

/// The entry `object:subindex` with the object's own default ([`ObjectDesc::resolve`]).
const fn find_entry(object: &'static ObjectDesc, subindex: u8) -> Option<EntryDesc> {
    match object.entry_desc(subindex) {
        Some(entry) => Some(object.resolve(entry)),
        None => None,
    }
}

/// The numeric default of `object:subindex` if it fits a u32.
const fn default_u32(object: Option<&'static ObjectDesc>, subindex: u8) -> Option<u32> {
    let object = match object {
        Some(o) => o,
        None => return None,
    };
    match find_entry(object, subindex) {
        Some(entry) => match entry.default().as_i128() {
            Some(v) if v >= 0 && v <= u32::MAX as i128 => Some(v as u32),
            _ => None,
        },
        None => None,
    }
}

/// The default of sub 0 (the count of an assignment or mapping), 0 if absent.
const fn default_count(object: Option<&'static ObjectDesc>) -> u8 {
    match default_u32(object, 0) {
        Some(n) if n <= 255 => n as u8,
        _ => 0,
    }
}

/// Bit length of a typed gap: a basic data type index 0x0001..=0x0007 (CiA 301 7.4.7.1).
const fn gap_bits(index: u16) -> u8 {
    match index {
        0x0001 => 1,
        0x0002 | 0x0005 => 8,
        0x0003 | 0x0006 => 16,
        0x0004 | 0x0007 => 32,
        _ => 0,
    }
}

const fn str_eq(a: &str, b: &str) -> bool {
    let (a, b) = (a.as_bytes(), b.as_bytes());
    if a.len() != b.len() {
        return false;
    }
    let mut i = 0;
    while i < a.len() {
        if a[i] != b[i] {
            return false;
        }
        i += 1;
    }
    true
}

/// The numeric defaults of sub 1..=sub 0 of an assignment or mapping object.
#[derive(Debug, Clone)]
pub struct DefaultValues {
    object: Option<&'static ObjectDesc>,
    next: u8,
    count: u8,
}

impl DefaultValues {
    fn of(object: Option<&'static ObjectDesc>) -> Self {
        Self {
            object,
            next: 1,
            count: default_count(object),
        }
    }
}

impl Iterator for DefaultValues {
    type Item = u32;

    fn next(&mut self) -> Option<u32> {
        while self.next <= self.count && self.next != 0 {
            let sub = self.next;
            self.next = self.next.wrapping_add(1);
            if let Some(v) = default_u32(self.object, sub) {
                return Some(v);
            }
        }
        None
    }
}

/// What [`DeviceDescription::validate`] found wrong.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum DescErrorKind {
    /// The object dictionary itself is invalid (index/subindex of the error).
    Dictionary(OdErrorKind),
    /// A vendor, device, order, group type or group name is empty.
    EmptyName,
    /// The dictionary has no identity object 0x1018.
    MissingIdentity,
    /// A default of 0x1018 (subindex given) differs from the identity.
    IdentityMismatch,
    /// 0x1008/0x1009/0x100A (index given) differs from the name/version.
    StringMismatch,
    /// Two SyncManagers have the same role (index = the second SM).
    SmRoleTwice,
    /// A SyncManager's control byte does not fit its role (index = SM).
    SmControlMismatch,
    /// A SyncManager lies outside the process RAM (index = SM).
    SmOutsideProcessRam,
    /// Two SyncManagers overlap (index = first SM, subindex = second SM).
    SmOverlap,
    /// A mailbox SyncManager is smaller than the smallest CoE frame (index = SM).
    MailboxTooSmall,
    /// Mailbox protocols without both mailbox SyncManagers, or only one of them.
    MailboxIncomplete,
    /// A bootstrap mailbox outside the process RAM, smaller than the smallest frame,
    /// overlapping itself, or without FoE among the protocols.
    BadBootstrapMailbox,
    /// Sub 0 of a mapping/assignment object counts more entries than it has.
    CountAboveEntries,
    /// A default mapping entry names an object or subindex that does not exist.
    MappedEntryMissing,
    /// A default mapping entry names an entry that is not PDO-mappable.
    MappedNotMappable,
    /// A default mapping entry names an entry mappable only in the other direction.
    MappedWrongDirection,
    /// A default mapping entry's bit length is not the entry's (or a gap's type length).
    MappedLengthMismatch,
    /// The default assignment names a PDO object that does not exist.
    AssignedPdoMissing,
    /// The default assignment names a PDO of the other direction (0x1C12 must assign
    /// 0x16xx, 0x1C13 0x1Axx).
    AssignedPdoWrongDirection,
    /// Default PDOs but no process-data SyncManager of that direction.
    PdoWithoutSm,
    /// Default PDOs but no FMMU of that direction.
    PdoWithoutFmmu,
    /// The default process image is larger than its SyncManager's reserved length.
    ImageLargerThanSm,
    /// The DC cycle limits are 0 or min > max.
    BadCycleLimits,
    /// The EEPROM size is not a multiple of 128 bytes between 256 bytes and 8 MB.
    BadEepromSize,
    /// A replicated PDO's factor limits are 0 or reversed, or exclude its default factor
    /// (index = the base PDO).
    BadOversamplingFactors,
    /// A replica of a replicated PDO is missing, of the other direction, or does not map
    /// what the base maps moved by the index increment (index = the replica, subindex =
    /// its number).
    ReplicaMismatch,
    /// An op mode names a SyncManager without process data, a PDO that does not exist or is
    /// of the other direction, a replica instead of its base, or a factor outside the
    /// group's limits or on a plain PDO (index = the PDO, subindex = the SyncManager).
    BadOpModePdo,
    /// An op mode's PDO assignment is larger than its SyncManager (subindex = the SM).
    OpModeImageLargerThanSm,
}

impl DescErrorKind {
    /// A human-readable description.
    pub const fn message(self) -> &'static str {
        match self {
            Self::Dictionary(kind) => kind.message(),
            Self::EmptyName => "empty vendor, device, order, group type or group name",
            Self::MissingIdentity => "the object dictionary has no identity object 0x1018",
            Self::IdentityMismatch => "0x1018 default differs from the identity",
            Self::StringMismatch => "0x1008/0x1009/0x100A default differs from the name/version",
            Self::SmRoleTwice => "two SyncManagers with the same role",
            Self::SmControlMismatch => "SyncManager control byte does not fit its role",
            Self::SmOutsideProcessRam => "SyncManager outside the process RAM",
            Self::SmOverlap => "SyncManagers overlap",
            Self::MailboxTooSmall => "mailbox SyncManager smaller than the smallest CoE frame",
            Self::MailboxIncomplete => "mailbox protocols need both mailbox SyncManagers",
            Self::BadBootstrapMailbox => {
                "bootstrap mailbox outside the process RAM, too small, overlapping itself or without FoE"
            }
            Self::CountAboveEntries => "sub 0 default counts more entries than the object has",
            Self::MappedEntryMissing => "PDO mapping names an entry that does not exist",
            Self::MappedNotMappable => "PDO mapping names an entry that is not PDO-mappable",
            Self::MappedWrongDirection => {
                "PDO mapping names an entry mappable only in the other direction"
            }
            Self::MappedLengthMismatch => "PDO mapping bit length differs from the entry's",
            Self::AssignedPdoMissing => "PDO assignment names a PDO that does not exist",
            Self::AssignedPdoWrongDirection => "PDO assignment names a PDO of the other direction",
            Self::PdoWithoutSm => "default PDOs without a process-data SyncManager",
            Self::PdoWithoutFmmu => "default PDOs without an FMMU of that direction",
            Self::ImageLargerThanSm => "default process image larger than its SyncManager",
            Self::BadCycleLimits => "DC cycle limits zero or minimum above maximum",
            Self::BadEepromSize => "EEPROM size not a multiple of 128 bytes in 256 B..8 MB",
            Self::BadOversamplingFactors => {
                "replicated PDO: factor limits zero or reversed, or excluding the default"
            }
            Self::ReplicaMismatch => {
                "replicated PDO: a replica is missing or does not map the base's objects moved by the index increment"
            }
            Self::BadOpModePdo => {
                "op mode: SyncManager without process data, unknown PDO, PDO of the other direction, a replica instead of its base, or a bad factor"
            }
            Self::OpModeImageLargerThanSm => "op mode: PDO assignment larger than its SyncManager",
        }
    }
}

/// A device description validation error: what and where.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct DescError {
    /// What is wrong.
    pub kind: DescErrorKind,
    /// Object index, or SyncManager number for SM errors.
    pub index: u16,
    /// Subindex, or the second SyncManager of an overlap.
    pub subindex: u8,
}

impl DescError {
    /// Creates an error.
    pub const fn new(kind: DescErrorKind, index: u16, subindex: u8) -> Self {
        Self {
            kind,
            index,
            subindex,
        }
    }

    /// The description of the kind (for a `const` panic message).
    pub const fn message(&self) -> &'static str {
        self.kind.message()
    }
}

impl fmt::Display for DescError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.kind {
            DescErrorKind::SmOverlap => write!(
                f,
                "device description: SM{} and SM{}: {}",
                self.index,
                self.subindex,
                self.message()
            ),
            DescErrorKind::SmRoleTwice
            | DescErrorKind::SmControlMismatch
            | DescErrorKind::SmOutsideProcessRam
            | DescErrorKind::MailboxTooSmall => {
                write!(
                    f,
                    "device description: SM{}: {}",
                    self.index,
                    self.message()
                )
            }
            DescErrorKind::EmptyName
            | DescErrorKind::MailboxIncomplete
            | DescErrorKind::BadBootstrapMailbox
            | DescErrorKind::BadCycleLimits
            | DescErrorKind::BadEepromSize => {
                write!(f, "device description: {}", self.message())
            }
            _ => write!(
                f,
                "device description: object {:#06X}:{:02X}: {}",
                self.index,
                self.subindex,
                self.message()
            ),
        }
    }
}

#[cfg(test)]
pub(crate) mod tests;
