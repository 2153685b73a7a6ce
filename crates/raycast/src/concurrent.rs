//! Seed 001's concurrent update and render: "rendering and update are concurrent tasks".
//! The update (casting every ray for the latest camera) runs in a worker thread into the back
//! buffer; the renderer reads the front buffer and swaps when a pass completes
//! (`cloud::double_buffer`, shared with HPR's seed 000 §5).

use std::sync::Arc;

use cloud::Camera;
use cloud::double_buffer::DoubleBuffer;

use crate::{CastParams, Frame, RayCaster, RayList, Result};

/// A ray caster updating in the background.
pub type ConcurrentCaster = DoubleBuffer<Camera, Result<Frame>>;

/// Starts a worker casting `rays` through `caster` for each posted camera.
pub fn spawn(caster: Arc<RayCaster>, rays: Arc<RayList>, params: CastParams) -> ConcurrentCaster {
    DoubleBuffer::spawn(move |camera: &Camera| caster.cast(&rays, camera, &params))
}
