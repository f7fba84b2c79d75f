//! What the firmware is built for: channel counts, the mailbox, the PDO configuration and
//! the process images. Every array and check of the application is sized from these.

/// Analog inputs (AD7689 channels, 0x6401:01..08).
pub const AI_CHANNELS: usize = 8;
/// Analog outputs (AD5663 channels, 0x6411:01..02).
pub const AO_CHANNELS: usize = 2;

/// Mailbox size (SM0 and SM1 length).
pub const MAILBOX_SIZE: usize = 128;

/// Size of the bootstrap mailbox (BOOT state, each direction): four times the standard
/// mailbox, so an update file moves in packets of 500 bytes.
pub const BOOTSTRAP_MAILBOX_SIZE: usize = 512;
/// Largest object transferred in several frames (segmented SDO, complete access).
pub const TRANSFER_BUFFER: usize = 512;
/// Emergencies that can wait for the mailbox.
pub const EMERGENCY_QUEUE: usize = 4;
/// Errors the pre-defined error field (0x1003) keeps. Each costs 4 B of RAM and a 28 B
/// entry description in flash, and the flash budget sets the limit: four hold a fault and
/// what followed it (e.g. the watchdog, the sync error, an output clamped), which the
/// Emergency queue of the same depth could have had waiting at once.
pub const ERROR_HISTORY: usize = 4;

/// RxPDO mapping objects the module offers (0x1600, 0x1601); on CAN each has its RPDO
/// communication parameter (0x1400, 0x1401).
pub const RX_PDOS: usize = 2;
/// TxPDO mapping objects the module offers (0x1A00..0x1A02); on CAN each has its TPDO
/// communication parameter (0x1800..0x1802).
pub const TX_PDOS: usize = 3;
/// Entries per mapping object.
pub const PDO_ENTRIES: usize = 8;
/// Largest process image per direction in bytes.
pub const MAX_IMAGE: usize = 32;
/// Largest number of mapped objects per direction.
pub const MAX_FIELDS: usize = 16;
