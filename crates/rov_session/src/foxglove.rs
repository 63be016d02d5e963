//! Foxglove's standard schemas in every session: the vehicle pose for the 3D panel, and
//! the camera video.
//!
//! The messages are the official SDK's types (`foxglove::messages`), encoded as protobuf
//! with the official descriptors, so Foxglove, Lichtblick and any protobuf reader decode
//! them without a file of ours. Pure: a pose or a frame in, bytes out (and back). The live
//! WebSocket server reuses [`channel_schema`], [`VehiclePose`] and the message functions.
//!
//! # Frames: NED in the station, ENU in the file
//!
//! The station works in NED and body FRD (Fossen): x north, y east, z down; body x
//! forward, y starboard, z down; heading clockwise from north. Foxglove's 3D panel follows
//! ROS (REP 103): z is up. The pose is therefore written as
//!
//! * frame [`WORLD_FRAME`] = **ENU**: x east, y north, z up; the origin is the surface
//!   above the starting point (z = −depth);
//! * frame [`VEHICLE_FRAME`] = **FLU**: x forward, y port, z up;
//! * the rotation world ← vehicle is `T · R_ned←frd(φ, θ, ψ) · D`, with `T` swapping north
//!   and east and negating down, `D = diag(1, −1, −1)`; so heading 0 (north) points the
//!   vehicle's x axis along world +y, heading 90° (east) along world +x, and nose-up pitch
//!   raises x above the horizontal.
//!
//! In the 3D panel (display frame `world`) the vehicle moves down as it dives, turns as it
//! yaws, and follows its horizontal track when the position is known. A Pro 4 measures no
//! horizontal position: a real dive shows depth and attitude at north = east = 0; a
//! simulated dive carries the simulator's north and east (from `/truth/state`).
//!
//! # Topics
//!
//! * `/tf`: `foxglove.FrameTransform` world → vehicle;
//! * `/vehicle/pose`: `foxglove.PoseInFrame` in `world`;
//! * `/vehicle/track`: `foxglove.PosesInFrame`, the last [`TRACK_WINDOW_S`] of positions
//!   every [`TRACK_SPACING_S`], written every [`TRACK_EVERY_S`] (show it as a line);
//! * `/camera/video`: `foxglove.CompressedVideo`, H.264 Annex B, one access unit per
//!   message, frame `camera`.

use std::borrow::Cow;
use std::collections::VecDeque;

use foxglove::Encode as _;
use foxglove::messages::{
    CompressedVideo, FrameTransform, Pose, PoseInFrame, PosesInFrame, Quaternion, Timestamp,
    Vector3,
};
use nalgebra::{Matrix3, Rotation3, UnitQuaternion};
use prost::Message as _;
use rov_dynamics::kinematics::Attitude;

use crate::record::{JSON_SCHEMA_ENCODING, NavRecord, Topic, TruthRecord, schema_of};

/// The world frame (ENU, origin at the surface above the start).
pub const WORLD_FRAME: &str = "world";
/// The vehicle's body frame (FLU).
pub const VEHICLE_FRAME: &str = "vehicle";
/// The camera's frame (Foxglove's optical convention).
pub const CAMERA_FRAME: &str = "camera";
/// The video format written.
pub const VIDEO_FORMAT: &str = "h264";

/// Spacing of the track's positions, s.
pub const TRACK_SPACING_S: f64 = 5.0;
/// Length of the track, s.
pub const TRACK_WINDOW_S: f64 = 1800.0;
/// A track message is written this often, s.
pub const TRACK_EVERY_S: f64 = 10.0;

/// The schema of a channel, for MCAP and the Foxglove WebSocket protocol alike.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ChannelSchema {
    /// Schema name (e.g. `foxglove.FrameTransform`, `topside.TelemetryNav`), empty for
    /// the raw topics.
    pub name: String,
    /// Schema encoding: `protobuf`, `jsonschema`, or empty.
    pub encoding: String,
    /// Schema data (a protobuf `FileDescriptorSet`, or JSON Schema text).
    pub data: Cow<'static, [u8]>,
    /// Message encoding: `protobuf`, `json` or `vr-pro4`.
    pub message_encoding: &'static str,
}

/// The schema of every known topic.
pub fn channel_schema(topic: Topic) -> ChannelSchema {
    let fox = match topic {
        Topic::Transform => FrameTransform::get_schema(),
        Topic::Pose => PoseInFrame::get_schema(),
        Topic::Track => PosesInFrame::get_schema(),
        Topic::Video => CompressedVideo::get_schema(),
        _ => None,
    };
    if let Some(s) = fox {
        return ChannelSchema {
            name: s.name,
            encoding: s.encoding,
            data: s.data,
            message_encoding: topic.encoding(),
        };
    }
    match schema_of(topic) {
        Some((name, json)) => ChannelSchema {
            name: name.to_string(),
            encoding: JSON_SCHEMA_ENCODING.to_string(),
            data: Cow::Owned(json.to_string().into_bytes()),
            message_encoding: topic.encoding(),
        },
        None => ChannelSchema {
            name: String::new(),
            encoding: String::new(),
            data: Cow::Borrowed(&[]),
            message_encoding: topic.encoding(),
        },
    }
}

/// A protobuf timestamp of a message time (the same time base as the log time).
fn stamp(t_ns: u64) -> Option<Timestamp> {
    let sec = u32::try_from(t_ns / 1_000_000_000).ok()?;
    Timestamp::new_checked(sec, (t_ns % 1_000_000_000) as u32)
}

/// The vehicle's pose in NED as the station knows it; see the module docs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct VehiclePose {
    /// Time, ns (the session's time base).
    pub t_ns: u64,
    /// North of the start, m (0 when unknown).
    pub north_m: f64,
    /// East of the start, m (0 when unknown).
    pub east_m: f64,
    /// Depth, m, positive down.
    pub depth_m: f64,
    /// Roll, degrees, starboard down.
    pub roll_deg: f64,
    /// Pitch, degrees, nose up.
    pub pitch_deg: f64,
    /// Heading, degrees clockwise from north.
    pub heading_deg: f64,
}

impl VehiclePose {
    /// The pose of a navigation record; north and east from the simulator's truth when
    /// given. `None` when depth or an attitude angle is not finite (nothing to show).
    pub fn from_nav(t_ns: u64, nav: &NavRecord, truth: Option<&TruthRecord>) -> Option<Self> {
        let finite = [nav.depth_m, nav.roll_deg, nav.pitch_deg, nav.heading_deg]
            .iter()
            .all(|x| x.is_finite());
        if !finite {
            return None;
        }
        let (north_m, east_m) = truth
            .filter(|t| t.north_m.is_finite() && t.east_m.is_finite())
            .map_or((0.0, 0.0), |t| (t.north_m, t.east_m));
        Some(Self {
            t_ns,
            north_m,
            east_m,
            depth_m: nav.depth_m,
            roll_deg: nav.roll_deg,
            pitch_deg: nav.pitch_deg,
            heading_deg: nav.heading_deg,
        })
    }

    /// Position in the world frame (ENU), m: [east, north, −depth].
    pub fn position_enu(&self) -> [f64; 3] {
        [self.east_m, self.north_m, -self.depth_m]
    }

    /// Rotation world (ENU) ← vehicle (FLU) as a unit quaternion [x, y, z, w].
    pub fn orientation_enu_flu(&self) -> [f64; 4] {
        let r_ned_frd = Attitude::new(
            self.roll_deg.to_radians(),
            self.pitch_deg.to_radians(),
            self.heading_deg.to_radians(),
        )
        .ned_from_body();
        let enu_from_ned = Matrix3::new(0.0, 1.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, -1.0);
        let frd_from_flu = Matrix3::from_diagonal(&nalgebra::Vector3::new(1.0, -1.0, -1.0));
        let m = enu_from_ned * r_ned_frd * frd_from_flu;
        let q = UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(m));
        [q.i, q.j, q.k, q.w]
    }

    fn pose(&self) -> Pose {
        let [x, y, z] = self.position_enu();
        let [qx, qy, qz, qw] = self.orientation_enu_flu();
        Pose {
            position: Some(Vector3 { x, y, z }),
            orientation: Some(Quaternion {
                x: qx,
                y: qy,
                z: qz,
                w: qw,
            }),
        }
    }
}

/// The transform world → vehicle of a pose.
pub fn frame_transform(p: &VehiclePose) -> FrameTransform {
    let pose = p.pose();
    FrameTransform {
        timestamp: stamp(p.t_ns),
        parent_frame_id: WORLD_FRAME.into(),
        child_frame_id: VEHICLE_FRAME.into(),
        translation: pose.position,
        rotation: pose.orientation,
    }
}

/// The pose in the world frame.
pub fn pose_in_frame(p: &VehiclePose) -> PoseInFrame {
    PoseInFrame {
        timestamp: stamp(p.t_ns),
        frame_id: WORLD_FRAME.into(),
        pose: Some(p.pose()),
    }
}

/// Encodes a Foxglove message as protobuf.
pub fn encode<M: prost::Message>(m: &M) -> Vec<u8> {
    m.encode_to_vec()
}

/// The recent track: positions every [`TRACK_SPACING_S`] over [`TRACK_WINDOW_S`], offered
/// as a message every [`TRACK_EVERY_S`].
#[derive(Debug, Clone, Default)]
pub struct Track {
    poses: VecDeque<VehiclePose>,
    last_emit_ns: Option<u64>,
}

impl Track {
    /// Adds a pose; returns the track message when one is due.
    pub fn push(&mut self, p: &VehiclePose) -> Option<PosesInFrame> {
        let spacing = (TRACK_SPACING_S * 1e9) as u64;
        let due_point = self
            .poses
            .back()
            .is_none_or(|b| p.t_ns < b.t_ns || p.t_ns - b.t_ns >= spacing);
        if due_point {
            if self.poses.back().is_some_and(|b| p.t_ns < b.t_ns) {
                // Time went backwards (a new time base): start over.
                self.poses.clear();
                self.last_emit_ns = None;
            }
            self.poses.push_back(*p);
            let window = (TRACK_WINDOW_S * 1e9) as u64;
            while self
                .poses
                .front()
                .is_some_and(|f| p.t_ns.saturating_sub(f.t_ns) > window)
            {
                self.poses.pop_front();
            }
        }
        let every = (TRACK_EVERY_S * 1e9) as u64;
        let due = self
            .last_emit_ns
            .is_none_or(|l| p.t_ns.saturating_sub(l) >= every);
        if !due {
            return None;
        }
        self.last_emit_ns = Some(p.t_ns);
        let mut poses: Vec<Pose> = self.poses.iter().map(VehiclePose::pose).collect();
        if !due_point {
            poses.push(p.pose());
        }
        Some(PosesInFrame {
            timestamp: stamp(p.t_ns),
            frame_id: WORLD_FRAME.into(),
            poses,
        })
    }
}

/// Truth older than this is not used for the pose's position, ns.
pub const TRUTH_MAX_AGE_NS: u64 = 1_000_000_000;

/// The encoded pose messages of one pose.
#[derive(Debug, Clone, PartialEq)]
pub struct PoseMessages {
    /// The pose.
    pub pose: VehiclePose,
    /// `/tf`: the `foxglove.FrameTransform`, protobuf.
    pub transform: Vec<u8>,
    /// `/vehicle/pose`: the `foxglove.PoseInFrame`, protobuf.
    pub pose_in_frame: Vec<u8>,
    /// `/vehicle/track`: the `foxglove.PosesInFrame` when one is due, protobuf.
    pub track: Option<Vec<u8>>,
}

/// The pose topics of a stream of records, the one derivation used by the session writer
/// and the live server: every navigation record gives a pose at most every
/// `interval_ns` (north and east from the latest truth record at most
/// [`TRUTH_MAX_AGE_NS`] old, else 0), and the track every [`TRACK_EVERY_S`].
#[derive(Debug, Clone)]
pub struct PoseTopics {
    interval_ns: u64,
    /// (time, north, east) of the latest truth record.
    last_truth: Option<(u64, f64, f64)>,
    last_pose_ns: Option<u64>,
    track: Track,
}

impl PoseTopics {
    /// Poses at most every `interval_ns` of record time; `u64::MAX`: none.
    pub fn new(interval_ns: u64) -> Self {
        Self {
            interval_ns,
            last_truth: None,
            last_pose_ns: None,
            track: Track::default(),
        }
    }

    /// Takes the position of a `/truth/state` record at `t_ns`.
    pub fn truth(&mut self, t_ns: u64, t: &TruthRecord) {
        self.last_truth =
            (t.north_m.is_finite() && t.east_m.is_finite()).then_some((t_ns, t.north_m, t.east_m));
    }

    /// The pose messages of a `/telemetry/nav` record at `t_ns`, when due.
    pub fn nav(&mut self, t_ns: u64, nav: &NavRecord) -> Option<PoseMessages> {
        if self.interval_ns == u64::MAX {
            return None;
        }
        let due = self
            .last_pose_ns
            .is_none_or(|l| t_ns < l || t_ns - l >= self.interval_ns);
        if !due {
            return None;
        }
        let truth = self
            .last_truth
            .filter(|(t, _, _)| t_ns.abs_diff(*t) <= TRUTH_MAX_AGE_NS)
            .map(|(_, north_m, east_m)| TruthRecord {
                north_m,
                east_m,
                ..TruthRecord::default()
            });
        VehiclePose::from_nav(t_ns, nav, truth.as_ref()).map(|p| self.pose(&p))
    }

    /// The messages of a pose from any source (it counts as the latest pose).
    pub fn pose(&mut self, p: &VehiclePose) -> PoseMessages {
        self.last_pose_ns = Some(p.t_ns);
        PoseMessages {
            pose: *p,
            transform: encode(&frame_transform(p)),
            pose_in_frame: encode(&pose_in_frame(p)),
            track: self.track.push(p).map(|t| encode(&t)),
        }
    }
}

/// Why a video access unit was refused or a video message skipped.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum VideoError {
    /// The data does not start with an Annex B start code.
    #[error("the access unit is not H.264 Annex B (no start code at its beginning)")]
    NotAnnexB,
    /// A key frame lacks a parameter set or the IDR slice.
    #[error("a key frame must carry SPS, PPS and an IDR slice; this one has NAL types {0:?}")]
    IncompleteKeyFrame(Vec<u8>),
    /// An IDR slice in an access unit not flagged as a key frame.
    #[error("the access unit holds an IDR slice but is not flagged as a key frame")]
    UnflaggedKeyFrame,
    /// The message is not a `foxglove.CompressedVideo`.
    #[error("not a foxglove.CompressedVideo message: {0}")]
    Decode(String),
    /// A format other than H.264.
    #[error("video format {0:?} (only \"h264\" is read)")]
    Format(String),
}

/// NAL unit types of an Annex B access unit, in order.
pub fn h264_nal_types(au: &[u8]) -> Vec<u8> {
    let mut out = Vec::new();
    let mut i = 0usize;
    while let Some(w) = au.get(i..i + 3) {
        if w == [0, 0, 1] {
            if let Some(h) = au.get(i + 3) {
                out.push(h & 0x1F);
            }
            i += 3;
        } else {
            i += 1;
        }
    }
    out
}

fn starts_annex_b(au: &[u8]) -> bool {
    au.starts_with(&[0, 0, 1]) || au.starts_with(&[0, 0, 0, 1])
}

/// NAL type of an IDR slice, SPS and PPS.
const NAL_IDR: u8 = 5;
const NAL_SPS: u8 = 7;
const NAL_PPS: u8 = 8;

/// Checks an access unit against its key-frame flag (see [`VideoError`]).
pub fn check_access_unit(au: &[u8], key_frame: bool) -> Result<(), VideoError> {
    if !starts_annex_b(au) {
        return Err(VideoError::NotAnnexB);
    }
    let types = h264_nal_types(au);
    let idr = types.contains(&NAL_IDR);
    if key_frame && !(idr && types.contains(&NAL_SPS) && types.contains(&NAL_PPS)) {
        return Err(VideoError::IncompleteKeyFrame(types));
    }
    if !key_frame && idr {
        return Err(VideoError::UnflaggedKeyFrame);
    }
    Ok(())
}

/// The `foxglove.CompressedVideo` message of an access unit captured at `t_ns`.
pub fn video_message(t_ns: u64, au: &[u8]) -> CompressedVideo {
    CompressedVideo {
        timestamp: stamp(t_ns),
        frame_id: CAMERA_FRAME.into(),
        data: prost::bytes::Bytes::copy_from_slice(au),
        format: VIDEO_FORMAT.into(),
    }
}

/// One video frame read from a session.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct VideoFrame {
    /// Capture time, ns (the message's log time).
    pub t_ns: u64,
    /// The H.264 access unit (Annex B).
    pub data: prost::bytes::Bytes,
    /// Whether it is a key frame (holds an IDR slice).
    pub key_frame: bool,
}

/// Decodes a `/camera/video` message.
pub fn decode_video(t_ns: u64, bytes: &[u8]) -> Result<VideoFrame, VideoError> {
    let m = CompressedVideo::decode(bytes).map_err(|e| VideoError::Decode(e.to_string()))?;
    if m.format != VIDEO_FORMAT {
        return Err(VideoError::Format(m.format));
    }
    if !starts_annex_b(&m.data) {
        return Err(VideoError::NotAnnexB);
    }
    let key_frame = h264_nal_types(&m.data).contains(&NAL_IDR);
    Ok(VideoFrame {
        t_ns,
        data: m.data,
        key_frame,
    })
}

/// Decodes a `/tf` message.
pub fn decode_transform(bytes: &[u8]) -> Result<FrameTransform, prost::DecodeError> {
    FrameTransform::decode(bytes)
}

/// Decodes a `/vehicle/pose` message.
pub fn decode_pose(bytes: &[u8]) -> Result<PoseInFrame, prost::DecodeError> {
    PoseInFrame::decode(bytes)
}

/// Decodes a `/vehicle/track` message.
pub fn decode_track(bytes: &[u8]) -> Result<PosesInFrame, prost::DecodeError> {
    PosesInFrame::decode(bytes)
}

/// Whether a message of a Foxglove topic decodes as its schema (video: an H.264 access
/// unit); the reason when it does not.
pub fn validate(topic: Topic, t_ns: u64, bytes: &[u8]) -> Result<(), String> {
    let r = match topic {
        Topic::Transform => decode_transform(bytes).map(|_| ()),
        Topic::Pose => decode_pose(bytes).map(|_| ()),
        Topic::Track => decode_track(bytes).map(|_| ()),
        Topic::Video => {
            return decode_video(t_ns, bytes)
                .map(|_| ())
                .map_err(|e| e.to_string());
        }
        _ => Ok(()),
    };
    r.map_err(|e| e.to_string())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pose(heading_deg: f64, pitch_deg: f64) -> VehiclePose {
        VehiclePose {
            t_ns: 1_500_000_000,
            north_m: 3.0,
            east_m: -2.0,
            depth_m: 7.5,
            roll_deg: 0.0,
            pitch_deg,
            heading_deg,
        }
    }

    /// Rotates a vehicle-frame (FLU) vector into the world (ENU).
    fn to_world(p: &VehiclePose, v: [f64; 3]) -> [f64; 3] {
        let [x, y, z, w] = p.orientation_enu_flu();
        let q = UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(w, x, y, z));
        let r = q * nalgebra::Vector3::new(v[0], v[1], v[2]);
        [r.x, r.y, r.z]
    }

    fn close(a: [f64; 3], b: [f64; 3]) -> bool {
        a.iter().zip(b).all(|(x, y)| (x - y).abs() < 1e-9)
    }

    #[test]
    fn ned_to_enu_axes() {
        let p = pose(0.0, 0.0);
        assert_eq!(p.position_enu(), [-2.0, 3.0, -7.5]);
        // Heading north: forward is world +y (north), up stays up, port is west.
        assert!(close(to_world(&p, [1.0, 0.0, 0.0]), [0.0, 1.0, 0.0]));
        assert!(close(to_world(&p, [0.0, 0.0, 1.0]), [0.0, 0.0, 1.0]));
        assert!(close(to_world(&p, [0.0, 1.0, 0.0]), [-1.0, 0.0, 0.0]));
        // Heading east: forward is world +x.
        assert!(close(
            to_world(&pose(90.0, 0.0), [1.0, 0.0, 0.0]),
            [1.0, 0.0, 0.0]
        ));
        // Nose up 30° heading north: forward rises.
        let up = to_world(&pose(0.0, 30.0), [1.0, 0.0, 0.0]);
        assert!(close(
            up,
            [0.0, 30f64.to_radians().cos(), 30f64.to_radians().sin()]
        ));
    }

    #[test]
    fn messages_round_trip_through_protobuf() {
        let p = pose(45.0, 5.0);
        let tf = frame_transform(&p);
        let back = decode_transform(&encode(&tf)).unwrap();
        assert_eq!(back, tf);
        assert_eq!(back.parent_frame_id, "world");
        assert_eq!(back.timestamp.unwrap().total_nanos(), 1_500_000_000);
        let s = channel_schema(Topic::Transform);
        assert_eq!(s.name, "foxglove.FrameTransform");
        assert_eq!(
            (s.encoding.as_str(), s.message_encoding),
            ("protobuf", "protobuf")
        );
        assert!(!s.data.is_empty());
        let j = channel_schema(Topic::Nav);
        assert_eq!(j.encoding, "jsonschema");
        assert!(channel_schema(Topic::Pro4Tx).name.is_empty());
    }

    #[test]
    fn track_is_bounded_and_periodic() {
        let mut t = Track::default();
        let mut emitted = 0;
        let mut longest = 0;
        for k in 0..(3 * 3600 * 10) {
            let mut p = pose(0.0, 0.0);
            p.t_ns = k * 100_000_000;
            if let Some(m) = t.push(&p) {
                emitted += 1;
                longest = longest.max(m.poses.len());
            }
        }
        assert_eq!(emitted, 3 * 360);
        assert!(
            longest <= (TRACK_WINDOW_S / TRACK_SPACING_S) as usize + 2,
            "{longest}"
        );
    }

    #[test]
    fn access_units_are_checked() {
        let key = [0, 0, 0, 1, 0x67, 1, 0, 0, 1, 0x68, 2, 0, 0, 1, 0x65, 3];
        let delta = [0, 0, 1, 0x41, 9, 9];
        assert_eq!(h264_nal_types(&key), vec![7, 8, 5]);
        assert!(check_access_unit(&key, true).is_ok());
        assert!(check_access_unit(&delta, false).is_ok());
        assert_eq!(
            check_access_unit(&key, false),
            Err(VideoError::UnflaggedKeyFrame)
        );
        assert!(matches!(
            check_access_unit(&delta, true),
            Err(VideoError::IncompleteKeyFrame(_))
        ));
        assert_eq!(
            check_access_unit(&[1, 2, 3], false),
            Err(VideoError::NotAnnexB)
        );
        let f = decode_video(7, &encode(&video_message(7, &key))).unwrap();
        assert!(f.key_frame);
        assert_eq!(&f.data[..], &key[..]);
        assert!(decode_video(7, &[0xFF, 0xFF, 0xFF]).is_err());
    }
}
