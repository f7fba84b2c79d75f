//! Fuzz target: any frames from the bus into coe-core's CANopen master, which is booting
//! and supervising three nodes (heartbeat, node guarding, synchronous and event-driven PDOs,
//! SYNC on its own clock), never panic; every call ends, `step` runs out of work within a
//! bound, and every frame the master sends is one it may send (NMT, SYNC, SDO request, guard
//! request or an RPDO it was configured with).
//!
//! Input: see `can_stream.rs`. Run: `cargo xtask fuzz --target can_master`.
#![no_main]

#[path = "can_stream.rs"]
mod can_stream;

use coe_core::canopen::master::config::{Identity, MasterConfig, NodeConfig, PdoConfig};
use coe_core::canopen::master::Master;
use coe_core::pdo::PdoEntry;
use libfuzzer_sys::fuzz_target;

fn node(id: u8, transmission_type: u8) -> NodeConfig {
    let mut n = NodeConfig::new(id);
    n.identity = Identity {
        device_type: 0x0002_0192,
        vendor_id: 0x1234,
        ..Identity::default()
    };
    let entries = [PdoEntry::new(0x6041, 0, 16), PdoEntry::new(0x6064, 0, 32)];
    let outputs = [PdoEntry::new(0x6040, 0, 16), PdoEntry::new(0x607A, 0, 32)];
    let mut t = PdoConfig::new(1, 0x180 + u16::from(id), transmission_type, &entries);
    t.deadline_ms = 20;
    n.tpdo[0] = Some(t);
    let mut r = PdoConfig::new(1, 0x200 + u16::from(id), transmission_type, &outputs);
    r.event_timer_ms = 10;
    n.rpdo[0] = Some(r);
    n.heartbeat_producer_ms = 10;
    n.heartbeat_consumer_ms = 30;
    n
}

fuzz_target!(|data: &[u8]| {
    let mut guarded = node(3, 255);
    guarded.heartbeat_consumer_ms = 0;
    guarded.guard_time_ms = 10;
    guarded.life_time_factor = 2;
    let mut optional = node(4, 1);
    optional.mandatory = false;
    let mut mandatory = node(2, 1);
    mandatory.mandatory = true;
    let cfg = MasterConfig {
        sync_period_us: 2_000,
        retry_ms: 50,
        boot_wait_ms: 20,
        ..MasterConfig::default()
    };
    let places = [mandatory, guarded, optional, NodeConfig::EMPTY];
    let Ok(mut m) = Master::<4, 16>::new(cfg, places) else {
        panic!("the configuration is valid");
    };
    m.start(0);
    let allowed = |id: u16| {
        id == 0
            || id == 0x80
            || (0x602..=0x604).contains(&id)
            || (0x702..=0x704).contains(&id)
            || id == 0x77F
            || (0x202..=0x204).contains(&id)
    };
    for (now, frame) in can_stream::frames(data) {
        m.receive(&frame, now);
        let mut steps = 0;
        while m.step(now) {
            steps += 1;
            assert!(steps < 1_000, "step does not run out of work");
            while let Some(f) = m.pop_tx() {
                assert!(allowed(f.id()), "the master sent {f:?}");
            }
        }
        while let Some(f) = m.pop_tx() {
            assert!(allowed(f.id()), "the master sent {f:?}");
        }
        while m.pop_event().is_some() {}
        let _ = m.next_deadline_us();
        for slot in 0..4 {
            let _ = m.input(slot, 0);
            let _ = m.set_output(slot, 0, &[1, 2, 3, 4, 5, 6]);
        }
    }
});
