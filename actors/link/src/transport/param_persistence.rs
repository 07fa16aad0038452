//! The parameter table and its writer thread, wired: the table's texts go to the writer, and
//! each write's outcome comes back to the table on the writer's thread, whose answer (held
//! PARAM_VALUEs, or the old values with a STATUSTEXT, see `services/params/saving.rs`) is sent
//! at once. The receive path only ever queues a text; the disk is the writer thread's alone.

use std::sync::{Arc, Mutex};

use kestrel_proto::Clock;

use super::{GraphSink, ParamWriter};
use crate::hub::Hub;
use crate::services::params::short_reason;

/// A writer thread that hands each text to `write` and reports back to `hub`'s parameter table,
/// which from now on holds its echoes until saved. What the table answers is sent on the hub's
/// links; values it puts back go to their owners through `graph`.
pub fn param_writer_for<F>(
    hub: &Arc<Mutex<Hub>>,
    graph: GraphSink,
    clock: Arc<dyn Clock>,
    write: F,
) -> std::io::Result<ParamWriter>
where
    F: FnMut(&str) -> std::io::Result<()> + Send + 'static,
{
    hub.lock().unwrap_or_else(|e| e.into_inner()).vehicle().hold_param_echoes_until_saved();
    let hub = Arc::clone(hub);
    ParamWriter::spawn_reporting(
        write,
        Box::new(move |batch, result| {
            let (to_graph, next) = {
                let mut hub = hub.lock().unwrap_or_else(|e| e.into_inner());
                let result = result.as_ref().map(|_| ()).map_err(short_reason);
                let out = hub.vehicle().on_params_saved(batch, result, clock.now());
                let to_graph = hub.dispatch(out);
                (to_graph, hub.vehicle().take_param_write())
            };
            if !to_graph.is_empty() {
                graph(to_graph);
            }
            next.map(|w| (w.batch, w.text))
        }),
    )
}
