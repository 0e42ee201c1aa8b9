//! Attentional supervisor (thesis Sec. 3.3, 4.3.2–4.3.4, 5.2.2–5.2.4): a long-term memory of
//! task schemas in the thesis's notation, a working memory tree of behaviours
//! (m, r, p, x, e, μ) kept by the `alive` process, attentional regulation (eq. 4.8, e = μ/λ,
//! winner-takes-all over exclusive resources, eq. 4.9), learning of task trees from segmented
//! demonstrations (Algorithm 4) and tick-driven execution with cooperative replanning and
//! dual-arm arbitration of a shared area. No ROS dependency: the node and the CLI drive it.
//!
//! Modules: [`schema`] (notation, parser, printer), [`ltm`] (validation, retrieval, learning
//! updates, atomic save), [`wm`] (tree and `alive`), [`state`] (variables V), [`attention`]
//! (λ, μ, e), [`teaching`] (Algorithm 4), [`executive`] ([`Supervisor`]), [`events`] (JSON-lines
//! stimuli), [`runner`] (script driver with a simulated robot manager).
//!
//! Interpretations where the thesis leaves room (each is tested):
//! * every concrete behaviour is re-evaluated every tick (the period λ only weighs emphasis),
//!   so a new stimulus yields a new command in the tick it arrives;
//! * the running action keeps its arm unless a competitor's emphasis exceeds it by
//!   `hysteresis` (default 10 %), or it stops being enabled/accessible (object not visible,
//!   subtask given to the person, releaser false);
//! * a behaviour whose children are all accomplished asserts its post-condition; while
//!   teaching, a demonstrated subtask ends when its releaser turns false;
//! * free variables of a schema entry (the arm `A` of eq. 4.11) are enumerated over the
//!   declared arms; the instances form a conflict group and the first one started wins;
//! * the central area is granted to the arm that first asked for it and released when that
//!   arm completes an action whose object lies outside it.
//!
//! ```
//! use cowork_supervisor::{Ltm, Supervisor, SupervisorConfig, Event, Decision};
//! let ltm = Ltm::parse(
//!     "schema(add(Obj), [(subtask(take,Obj), hand.free)], Obj.taken).\n\
//!      schema(subtask(take,Obj), [(foa1(Obj), true)], Obj.taken).\n\
//!      schema(foa1(Obj), [], foa1.done, foa).\n",
//! ).unwrap();
//! let mut sup = Supervisor::new(ltm, "add(water)", SupervisorConfig::default()).unwrap();
//! let d = sup.tick_vec(0.0);
//! assert!(d.iter().any(|d| matches!(d, Decision::Action { label, .. } if label == "foa1(water)")));
//! sup.handle(&Event::ActionDone { arm: None, label: "foa1(water)".into() }, 0.5);
//! let d = sup.tick_vec(0.51);
//! assert!(d.iter().any(|d| matches!(d, Decision::TaskAccomplished { .. })));
//! ```

pub mod attention;
pub mod error;
pub mod events;
pub mod executive;
pub mod ltm;
pub mod runner;
pub mod schema;
pub mod state;
pub mod teaching;
pub mod wm;

pub use attention::SupervisorConfig;
pub use error::{Error, Result, Warning};
pub use events::{Event, GripperState, ObjectObs, TimedEvent, parse_jsonl};
pub use executive::{Decision, Grant, Mode, Supervisor, WmNodeView, WmSnapshot};
pub use ltm::Ltm;
pub use runner::{Record, RunConfig, RunReport, SimRobot};
pub use schema::{ActionKind, Document, Term};
pub use state::State;
