//! The `foxglove.*` messages the log carries, as typed structs, with Foxglove's own published
//! JSON Schemas (`schemas/foxglove/`, MIT, copied unchanged; `SOURCE.md` there names the commit).
//! Only the fields Foxglove's schemas define; every required field is written.

use serde::{Deserialize, Serialize};

/// A `foxglove.*` schema: its name and Foxglove's published text.
pub type OfficialSchema = (&'static str, &'static str);

pub const FRAME_TRANSFORMS: OfficialSchema =
    ("foxglove.FrameTransforms", include_str!("../../schemas/foxglove/FrameTransforms.json"));
pub const LOG: OfficialSchema = ("foxglove.Log", include_str!("../../schemas/foxglove/Log.json"));
pub const POSE_IN_FRAME: OfficialSchema =
    ("foxglove.PoseInFrame", include_str!("../../schemas/foxglove/PoseInFrame.json"));
pub const SCENE_UPDATE: OfficialSchema =
    ("foxglove.SceneUpdate", include_str!("../../schemas/foxglove/SceneUpdate.json"));

/// Every `foxglove.*` schema the log uses.
#[cfg(test)]
pub(crate) const SCHEMAS: [OfficialSchema; 4] = [FRAME_TRANSFORMS, LOG, POSE_IN_FRAME, SCENE_UPDATE];

/// `time`: seconds and nanoseconds since the Unix epoch.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Time {
    pub sec: u64,
    pub nsec: u32,
}

impl Time {
    pub fn from_ns(ns: u64) -> Self {
        Self { sec: ns / 1_000_000_000, nsec: (ns % 1_000_000_000) as u32 }
    }
    pub const ZERO: Time = Time { sec: 0, nsec: 0 };
}

#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Vector3 {
    pub x: f64,
    pub y: f64,
    pub z: f64,
}

impl From<[f64; 3]> for Vector3 {
    fn from([x, y, z]: [f64; 3]) -> Self {
        Self { x, y, z }
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Quaternion {
    pub x: f64,
    pub y: f64,
    pub z: f64,
    pub w: f64,
}

impl From<nalgebra::UnitQuaternion<f64>> for Quaternion {
    fn from(q: nalgebra::UnitQuaternion<f64>) -> Self {
        Self { x: q.i, y: q.j, z: q.k, w: q.w }
    }
}

impl Quaternion {
    pub const IDENTITY: Quaternion = Quaternion { x: 0.0, y: 0.0, z: 0.0, w: 1.0 };
}

#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Pose {
    pub position: Vector3,
    pub orientation: Quaternion,
}

impl Pose {
    pub const IDENTITY: Pose = Pose { position: Vector3 { x: 0.0, y: 0.0, z: 0.0 }, orientation: Quaternion::IDENTITY };

    pub fn from_isometry(t: &nalgebra::Isometry3<f64>) -> Self {
        let v = t.translation.vector;
        Self { position: Vector3 { x: v.x, y: v.y, z: v.z }, orientation: t.rotation.into() }
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Color {
    pub r: f64,
    pub g: f64,
    pub b: f64,
    pub a: f64,
}

/// `foxglove.PoseInFrame`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PoseInFrame {
    pub timestamp: Time,
    pub frame_id: String,
    pub pose: Pose,
}

/// `foxglove.FrameTransform`: the child frame's pose in the parent frame.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FrameTransform {
    pub timestamp: Time,
    pub parent_frame_id: String,
    pub child_frame_id: String,
    pub translation: Vector3,
    pub rotation: Quaternion,
}

/// `foxglove.FrameTransforms`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FrameTransforms {
    pub transforms: Vec<FrameTransform>,
}

/// `foxglove.Log`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Log {
    pub timestamp: Time,
    /// 2 = INFO.
    pub level: u8,
    pub message: String,
    pub name: String,
    pub file: String,
    pub line: u32,
}

/// `foxglove.SceneEntityDeletion`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SceneEntityDeletion {
    pub timestamp: Time,
    /// 0 = matching id, 1 = all.
    #[serde(rename = "type")]
    pub kind: u8,
    pub id: String,
}

/// `foxglove.KeyValuePair`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct KeyValuePair {
    pub key: String,
    pub value: String,
}

/// `foxglove.ArrowPrimitive`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ArrowPrimitive {
    pub pose: Pose,
    pub shaft_length: f64,
    pub shaft_diameter: f64,
    pub head_length: f64,
    pub head_diameter: f64,
    pub color: Color,
}

/// `foxglove.CubePrimitive`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CubePrimitive {
    pub pose: Pose,
    pub size: Vector3,
    pub color: Color,
}

/// `foxglove.LinePrimitive`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct LinePrimitive {
    /// 0 = line strip, 1 = loop, 2 = list.
    #[serde(rename = "type")]
    pub kind: u8,
    pub pose: Pose,
    pub thickness: f64,
    pub scale_invariant: bool,
    pub points: Vec<Vector3>,
    pub color: Color,
    pub colors: Vec<Color>,
    pub indices: Vec<u32>,
}

/// `foxglove.TextPrimitive`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TextPrimitive {
    pub pose: Pose,
    pub billboard: bool,
    pub font_size: f64,
    pub scale_invariant: bool,
    pub color: Color,
    pub text: String,
}

/// `foxglove.SceneEntity`; the primitive kinds this project draws nothing with are always
/// empty (written, as Foxglove's schema requires them).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SceneEntity {
    pub timestamp: Time,
    pub frame_id: String,
    pub id: String,
    pub lifetime: Time,
    pub frame_locked: bool,
    pub metadata: Vec<KeyValuePair>,
    pub arrows: Vec<ArrowPrimitive>,
    pub cubes: Vec<CubePrimitive>,
    pub spheres: Vec<CubePrimitive>,
    pub cylinders: Vec<serde_json::Value>,
    pub lines: Vec<LinePrimitive>,
    pub triangles: Vec<serde_json::Value>,
    pub texts: Vec<TextPrimitive>,
    pub models: Vec<serde_json::Value>,
}

impl SceneEntity {
    /// An empty entity `id` in `frame_id`, kept until replaced.
    pub fn new(time_ns: u64, frame_id: &str, id: &str) -> Self {
        Self {
            timestamp: Time::from_ns(time_ns),
            frame_id: frame_id.into(),
            id: id.into(),
            lifetime: Time::ZERO,
            frame_locked: true,
            metadata: Vec::new(),
            arrows: Vec::new(),
            cubes: Vec::new(),
            spheres: Vec::new(),
            cylinders: Vec::new(),
            lines: Vec::new(),
            triangles: Vec::new(),
            texts: Vec::new(),
            models: Vec::new(),
        }
    }
}

/// `foxglove.SceneUpdate`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SceneUpdate {
    pub deletions: Vec<SceneEntityDeletion>,
    pub entities: Vec<SceneEntity>,
}

#[cfg(test)]
mod tests {
    use sha2::{Digest, Sha256};

    use super::SCHEMAS;

    /// The copies are Foxglove's files unchanged: their hashes are those `SOURCE.md` records.
    #[test]
    fn the_embedded_schemas_are_the_published_files() {
        let source = include_str!("../../schemas/foxglove/SOURCE.md");
        for (name, text) in SCHEMAS {
            let file = format!("{}.json", name.trim_start_matches("foxglove."));
            let hash: String = Sha256::digest(text.as_bytes()).iter().map(|b| format!("{b:02x}")).collect();
            assert!(source.contains(&format!("| {file} | {hash} |")), "{file}: sha256 {hash} is not in SOURCE.md");
            let v: serde_json::Value = serde_json::from_str(text).unwrap();
            assert_eq!(v["title"], name, "{file}");
        }
        assert!(include_str!("../../schemas/foxglove/LICENSE").starts_with("MIT License"));
    }
}
