//! The `can-gateway` product's tasks as the board's PDI-side CPU: the firmware's own PDI task
//! ([`PdiTask`] around [`SlaveApp`] with the [`Gateway`]), its CAN task
//! ([`firmware::stacks::canopen::task::run`] with the gateway as host) on the board's CAN
//! bus, its SYNC0 task (the edge into the [`CycleMarks`]) and its SysTick, in priority
//! order on virtual time, as the gateway's RTIC application runs them. The gateway's image
//! is not built yet (over the application slot: docs/book/gateway.md), so this is the
//! gateway's logic through the real ET1100 driver on the ESC model, not the image.
//!
//! The CANopen nodes of the test (`InProcessSlave`s on the same bus) ride along: they are
//! served at every event of this CPU and at their own deadlines, so the board needs no other
//! participant.

use crate::models::can::{PortId, SharedCanBus};
use crate::models::esc::SyncEdge;
use crate::models::spi::EscSpi;
use crate::rig::board::{BoardIo, PdiCpu};
use crate::rig::can_slave::{InProcessSlave, SlaveIdentity};
use crate::rig::firmware_cpu::{CAN_TX_BUFFERS, TICK_NS};
use coe_core::canopen::CanFrame;
use et1100::{Et1100, SpiPdi};
use firmware::products::can_gateway::stage::CycleMarks;
use firmware::products::can_gateway::{self, Gateway};
use firmware::stacks::canopen::task::{self as can_task, CanController, CanInbox};
use firmware::stacks::ethercat::pdi_task::{PdiTask, Wake};
use firmware::stacks::ethercat::SlaveApp;
use std::cell::RefCell;
use std::rc::Rc;

/// The gateway's CAN1 on the board's bus (three transmit buffers).
struct Controller {
    bus: SharedCanBus,
    port: PortId,
}

impl CanController for Controller {
    fn receive(&mut self) -> Option<CanFrame> {
        self.bus.borrow_mut().receive(self.port).map(|(_, f)| f)
    }

    fn transmit(&mut self, frame: &CanFrame) -> bool {
        let mut bus = self.bus.borrow_mut();
        if bus.pending(self.port) >= CAN_TX_BUFFERS {
            return false;
        }
        bus.send(self.port, *frame);
        true
    }
}

/// Most CAN task activations in a row (a flooded bus cannot stop virtual time).
const MAX_CAN_RUNS: usize = 32;

/// The gateway's tasks and the nodes on its bus.
pub struct GatewayCpu {
    esc: Et1100<SpiPdi<EscSpi>>,
    task: Box<PdiTask<Gateway>>,
    marks: CycleMarks,
    can: Controller,
    inbox: CanInbox,
    next_tick_ns: u64,
    slaves: Nodes,
    bus: SharedCanBus,
}

/// The CANopen nodes on the gateway's bus, shared with the test that drives them.
#[derive(Clone)]
pub struct Nodes {
    slaves: Rc<RefCell<Vec<InProcessSlave>>>,
    bus: SharedCanBus,
}

impl Nodes {
    /// Runs `f` on the node with `node_id`.
    pub fn with<R>(&self, node_id: u8, f: impl FnOnce(&mut InProcessSlave) -> R) -> R {
        let mut slaves = self.slaves.borrow_mut();
        let s = slaves
            .iter_mut()
            .find(|s| s.node.node_id() == node_id)
            .unwrap_or_else(|| panic!("no node {node_id}"));
        f(s)
    }

    /// Powers node `node_id` off or on.
    pub fn power(&self, node_id: u8, on: bool) {
        let bus = self.bus.clone();
        self.with(node_id, |s| s.power(&mut bus.borrow_mut(), on));
    }
}

impl GatewayCpu {
    /// The gateway at power-up on `io`, with CANopen nodes `nodes` (node-ID, identity) on its
    /// bus.
    pub fn new(io: BoardIo, nodes: &[(u8, SlaveIdentity)]) -> Self {
        let bus = io.can.bus.clone();
        let slaves = Nodes {
            slaves: Rc::new(RefCell::new(
                nodes
                    .iter()
                    .map(|(id, identity)| {
                        InProcessSlave::attach(&mut bus.borrow_mut(), *id, *identity)
                    })
                    .collect(),
            )),
            bus: bus.clone(),
        };
        let app = SlaveApp::new(can_gateway::CONFIG, can_gateway::application());
        let mut cpu = Self {
            esc: Et1100::new(SpiPdi::new(io.esc.clone())),
            task: Box::new(PdiTask::new(app)),
            marks: CycleMarks::new(),
            can: Controller {
                bus: io.can.bus.clone(),
                port: io.can.port,
            },
            inbox: CanInbox::new(),
            next_tick_ns: io.now_ns() + TICK_NS,
            slaves,
            bus,
        };
        let ready = io.esc.esc().borrow().pdi_operational();
        cpu.task.start(&mut cpu.esc, ready);
        cpu
    }

    /// The gateway.
    pub fn gateway(&self) -> &Gateway {
        self.task.app().application()
    }

    /// The gateway, to change.
    pub fn gateway_mut(&mut self) -> &mut Gateway {
        self.task.app_mut().application_mut()
    }

    /// The CANopen nodes on the bus (a handle for the test).
    pub fn nodes(&self) -> Nodes {
        self.slaves.clone()
    }

    fn pdi_task(&mut self, io: &BoardIo, edge: bool) {
        let wake = Wake {
            edge,
            line_asserted: edge,
            poll: !edge,
            pdi_ready: io.esc.esc().borrow().pdi_operational(),
        };
        let line = io.esc.clone();
        let done = self.task.run(
            &mut self.esc,
            &self.marks,
            io.now_ns(),
            wake,
            || line.irq(),
            |_| {},
        );
        // The mailbox task (below the PDI task) runs its steps before the harness's next
        // event: the host-compiled firmware takes no time.
        if done.serve_mailbox {
            self.task
                .serve_mailbox(&mut self.esc, &self.marks, io.now_ns());
        }
        let g = self.gateway();
        if g.master.pending_tx() > 0 || g.work_waiting(io.now_ns()) {
            self.can_task(io);
        }
    }

    fn can_task(&mut self, io: &BoardIo) {
        for _ in 0..MAX_CAN_RUNS {
            let out = can_task::run(
                &mut self.can,
                &mut self.inbox,
                self.task.app_mut(),
                &self.marks,
                io.now_ns(),
            );
            if !out.run_again {
                break;
            }
        }
        self.gateway_mut().inbox_overruns = self.inbox.overruns();
    }

    fn serve_slaves(&mut self, now_ns: u64) {
        let mut bus = self.bus.borrow_mut();
        for s in self.slaves.slaves.borrow_mut().iter_mut() {
            s.service(&mut bus, now_ns);
        }
    }
}

impl PdiCpu for GatewayCpu {
    fn as_any(&self) -> Option<&dyn std::any::Any> {
        Some(self)
    }

    fn on_sync0(&mut self, io: &mut BoardIo, edge: &SyncEdge) {
        self.marks.record_sync0(edge.time_ns);
        self.pdi_task(io, false);
    }

    fn on_irq(&mut self, io: &mut BoardIo) {
        self.pdi_task(io, true);
    }

    fn on_can_rx(&mut self, io: &mut BoardIo) {
        self.can_task(io);
    }

    fn poll(&mut self, io: &mut BoardIo) {
        self.serve_slaves(io.now_ns());
    }

    fn next_timer_ns(&self) -> Option<u64> {
        let master = self.gateway().master.next_deadline_us().map(|t| t * 1000);
        let now = self.bus.borrow().now_ns();
        self.slaves
            .slaves
            .borrow()
            .iter()
            .filter_map(|s| s.next_ns(now))
            .collect::<Vec<_>>()
            .into_iter()
            .chain(master.filter(|t| *t > now))
            .chain([self.next_tick_ns])
            .min()
    }

    /// The tick (the PDI task's background work and the CAN task), the master's and the
    /// nodes' deadlines.
    fn on_timer(&mut self, io: &mut BoardIo) {
        let now = io.now_ns();
        if now >= self.next_tick_ns {
            self.next_tick_ns = now.max(self.next_tick_ns) + TICK_NS;
            self.pdi_task(io, false);
        }
        self.can_task(io);
        self.serve_slaves(now);
    }
}
