//! HPR in the background (seed 000 §5): a worker thread computes the visible set for the
//! latest viewpoint while the front buffer, the last finished set, is rendered.

use std::sync::Arc;

use cloud::double_buffer::DoubleBuffer;
use cloud::glam::DVec3;
use hull::ConvexHull;

use crate::{HprError, HprParams, Visibility, visible};

/// A background HPR: post viewpoints, swap, read the front buffer.
pub type BackgroundHpr = DoubleBuffer<DVec3, Result<Visibility, HprError>>;

/// Starts a worker computing HPR of `points` with `params` and `hull` for each posted eye.
pub fn spawn(
    points: Arc<Vec<DVec3>>,
    params: HprParams,
    hull: Box<dyn ConvexHull>,
) -> BackgroundHpr {
    DoubleBuffer::spawn(move |eye: &DVec3| visible(&points, *eye, &params, hull.as_ref()))
}

#[cfg(test)]
mod tests {
    use cloud::synth::sphere_scene;

    use super::*;

    #[test]
    fn background_result_equals_the_direct_one() {
        let scene = sphere_scene(2_000);
        let points = Arc::new(scene.cloud.positions.clone());
        let mut bg = spawn(
            Arc::clone(&points),
            HprParams::default(),
            hull::by_name("own").unwrap(),
        );
        let eye = DVec3::new(0.0, 1.0, 3.0);
        let s = bg.request(eye);
        bg.wait_for(s).unwrap();
        let front = bg.front().unwrap();
        let direct = visible(
            &points,
            eye,
            &HprParams::default(),
            hull::by_name("own").unwrap().as_ref(),
        )
        .unwrap();
        assert_eq!(front.request, eye);
        assert_eq!(front.result.as_ref().unwrap().visible, direct.visible);
    }
}
