//! The [`Stopper`]: how other threads stop a running loop.

use std::sync::Arc;

use crate::loop_link::LoopLink;
use crate::stop::StopRequest;

/// Stops a loop from another thread (cheap to clone, `Send + Sync`).
#[derive(Clone, Debug)]
pub struct Stopper {
    shared: Arc<LoopLink>,
}

impl Stopper {
    pub(crate) fn new(shared: Arc<LoopLink>) -> Self {
        Self { shared }
    }

    /// Asks the loop to stop at its next tick (motors are made safe).
    pub fn stop(&self) {
        self.shared.stop.request(StopRequest::Stop);
    }

    /// Emergency stop: takes effect at the loop's next tick.
    pub fn emergency_stop(&self) {
        self.shared.stop.request(StopRequest::EmergencyStop);
    }

    /// Sends `request`.
    pub fn request(&self, request: StopRequest) {
        self.shared.stop.request(request);
    }

    /// Whether the loop is between its start and its end.
    pub fn is_running(&self) -> bool {
        self.shared.is_running()
    }

    /// Whether motor-off has gone out on every bus (by the loop's safe stop or the
    /// supervisor's): after this, exiting the process leaves no motor commanded to torque by
    /// this run, confirmed or not.
    pub fn motors_off_sent(&self) -> bool {
        self.shared.vitals.motors_off_sent()
    }
}
