//! The rig's light as the exported file carries it (`asset.extras.prt.light`).

use serde_json::{Value, json};

use crate::light::LightCoefficients;
use crate::math::sh::rotation::ShRotation;
use crate::scene::Up;

/// `light` (in the frame of a scene whose up axis is `up`) in the exported file's y-up frame:
/// what `prt-bake light --up y` writes, so that a runtime can relight the `.glb` with the rig
/// it was exported with and no second file.
pub(super) fn light_in_gltf_frame(light: &LightCoefficients, up: Up) -> LightCoefficients {
    match up {
        Up::Y => light.clone(),
        up => {
            let turn = Up::Y.from_z_up() * up.from_z_up().transpose();
            light.rotated(&ShRotation::from_matrix(light.order(), turn))
        }
    }
}

/// `asset.extras.prt.light`: [`LightCoefficients::to_json`]'s object and the frame it is in.
pub(super) fn light_json(light: &LightCoefficients) -> Value {
    let mut json: Value = serde_json::from_str(&light.to_json()).expect("to_json writes JSON");
    json["frame"] = json!("this file's (+Y up): prt-bake light RIG --up y");
    json
}
