//! Fuzz target: the et1100 driver's helpers and decoders on whatever an ESC shifts back.
//!
//! The driver runs on both PDIs, the SPI one (`SpiPdi`) and the memory-mapped one
//! (`MemoryPdi`, 8 and 16 bit), over buses that answer every read with the fuzzer's bytes and
//! fail when they run out. Byte 0 picks the PDI; then each op byte picks a helper (register
//! decoders, SyncManager and mailbox access with fuzzed SyncManager registers, EEPROM reads
//! with busy polling, event samples). Nothing may panic, loop without bound or touch the bus
//! outside the access the helper documents (a helper that
//! polls without bound shows as a libFuzzer timeout).
#![no_main]

use embedded_hal::spi::{ErrorKind, ErrorType, Operation, SpiDevice};
use et1100::{BusWidth, Et1100, MemoryBus, MemoryPdi, Pdi, SpiPdi, SyncManager};
use libfuzzer_sys::fuzz_target;

/// The fuzzer's bytes as the bus's answers.
struct Answers<'a> {
    data: &'a [u8],
}

impl Answers<'_> {
    fn byte(&mut self) -> Result<u8, ErrorKind> {
        let (&b, rest) = self.data.split_first().ok_or(ErrorKind::Other)?;
        self.data = rest;
        Ok(b)
    }
}

impl ErrorType for Answers<'_> {
    type Error = ErrorKind;
}

impl SpiDevice<u8> for Answers<'_> {
    fn transaction(&mut self, operations: &mut [Operation<'_, u8>]) -> Result<(), ErrorKind> {
        for op in operations {
            match op {
                Operation::Read(buf) => buf.iter_mut().try_for_each(|b| {
                    *b = self.byte()?;
                    Ok(())
                })?,
                Operation::Transfer(read, _) => read.iter_mut().try_for_each(|b| {
                    *b = self.byte()?;
                    Ok(())
                })?,
                Operation::TransferInPlace(buf) => buf.iter_mut().try_for_each(|b| {
                    *b = self.byte()?;
                    Ok(())
                })?,
                Operation::Write(_) | Operation::DelayNs(_) => {}
            }
        }
        Ok(())
    }
}

impl MemoryBus for Answers<'_> {
    type Error = ErrorKind;

    fn read_u8(&mut self, _offset: u16) -> Result<u8, ErrorKind> {
        self.byte()
    }

    fn write_u8(&mut self, _offset: u16, _value: u8) -> Result<(), ErrorKind> {
        Ok(())
    }

    fn read_u16(&mut self, _offset: u16) -> Result<u16, ErrorKind> {
        Ok(u16::from_le_bytes([self.byte()?, self.byte()?]))
    }

    fn write_u16(&mut self, _offset: u16, _value: u16) -> Result<(), ErrorKind> {
        Ok(())
    }
}

/// Polls allowed per EEPROM wait.
const MAX_POLLS: u32 = 8;

fn exercise<P: Pdi>(esc: &mut Et1100<P>, ops: &[u8]) {
    let mut buf = [0u8; 256];
    for (i, op) in ops.iter().enumerate() {
        let arg = ops.get(i + 1).copied().unwrap_or(0);
        match op % 12 {
            0 => {
                let _ = esc.low_events().map(|e| e.bits());
                let _ = esc
                    .events()
                    .map(|e| e.contains(et1100::AlEvents::sm(arg % 16)));
            }
            1 => {
                let _ = esc.read_al_control().map(|c| (c.state(), c.error_ack()));
                let _ = esc.read_al_status().map(|s| (s.state(), s.error()));
            }
            2 => {
                let _ = esc.esc_info();
                let _ = esc.dl_status();
                let _ = esc.station_address();
            }
            3 => {
                let _ = esc.watchdog_status();
                let _ = esc.watchdog_counters();
                let _ = esc.watchdog_time_process_data();
            }
            4 => {
                if let Ok(sm) = esc.read_sm(arg) {
                    let _ = (
                        sm.mode(),
                        sm.direction(),
                        sm.last_address(),
                        sm.repeat_requested(),
                    );
                    let _ = esc.read_mailbox(&sm, &mut buf);
                    let _ = esc.ack_repeat(arg, &sm);
                }
            }
            5 => {
                // SyncManager registers straight from the fuzzer (start, length anywhere).
                let mut raw = [0u8; 8];
                for (j, b) in raw.iter_mut().enumerate() {
                    *b = ops.get(i + 1 + j).copied().unwrap_or(0);
                }
                let sm = SyncManager::from_bytes(raw);
                assert_eq!(SyncManager::from_bytes(sm.to_bytes()), sm);
                let _ = esc.read_mailbox(&sm, &mut buf);
                let n = usize::from(arg);
                let _ = esc.write_mailbox(&sm, &buf[..n.min(buf.len())]);
            }
            6 => {
                let _ = esc
                    .eeprom_status()
                    .map(|s| (s.busy(), s.read_size(), s.has_error()));
                let n = usize::from(arg) % 64;
                let _ = esc.eeprom_read(u32::from(arg), &mut buf[..n], MAX_POLLS);
            }
            7 => {
                let _ = esc.sync_activation();
                let _ = esc.sync_pulse_length();
                let _ = esc.system_time();
            }
            8 => {
                let n = usize::from(arg) % 64 + 1;
                let _ = esc.read(u16::from(arg) << 8 | 0xF0, &mut buf[..n]);
            }
            9 => {
                let n = usize::from(arg) % 64;
                let _ = esc.write(0xFFFF - u16::from(arg), &buf[..n]);
            }
            10 => {
                let _ = esc.read_process_data(u16::from(arg) << 4, &mut buf[..16]);
            }
            _ => {
                let _ = esc.event_mask();
            }
        }
    }
}

fuzz_target!(|data: &[u8]| {
    let [pdi, ops_len, rest @ ..] = data else {
        return;
    };
    let n = usize::from(*ops_len).min(rest.len());
    let (ops, answers) = rest.split_at(n);
    let bus = Answers { data: answers };
    match pdi % 3 {
        0 => exercise(&mut Et1100::new(SpiPdi::new(bus)), ops),
        1 => exercise(&mut Et1100::new(MemoryPdi::new(bus, BusWidth::Bits8)), ops),
        _ => exercise(&mut Et1100::new(MemoryPdi::new(bus, BusWidth::Bits16)), ops),
    }
});
