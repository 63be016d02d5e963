//! The simulator's camera: a synthetic forward view rendered from the vehicle's pose, in
//! plain code (no GStreamer, no clock: pose, lights and time are arguments).
//!
//! # Scene
//! * A flat **seabed** at [`SimScene::seabed_depth_m`] (default 6 m): sand with a coarse
//!   tile texture, a survey **grid** of dark lines every [`SimScene::grid_spacing_m`]
//!   (2 m, on multiples of the spacing in north and east), and scattered **landmarks**
//!   (coloured discs with a dark rim, like survey markers or rocks): in each square cell of
//!   [`SimScene::landmark_cell_m`] (3 m) a hash of the cell and the seed decides whether
//!   there is one, where, how big and which colour. Deterministic for a seed.
//! * The **water surface** (z = 0) above: inside Snell's window (48.6° from the vertical,
//!   n = 1.333) the bright sky with the refracted sun (azimuth [`SimScene::sun_azimuth_deg`]);
//!   outside it the dark total reflection, both rippled by two fixed wave trains.
//! * **Water**: a colour that darkens with depth (daylight falls off as
//!   `exp(−depth / light_falloff_m)`) and with looking down; everything fades into it with
//!   distance (transmission `exp(−d / visibility)`), the **visibility** growing from
//!   [`SimScene::visibility_m`] with the lights off to that plus
//!   [`SimScene::lights_visibility_gain_m`] at 100 %. The lights also add a spot of
//!   illumination along the vehicle's nose that falls off with distance.
//!
//! # Camera
//! A pinhole camera ([`CameraModel`], 640×480 and 75° horizontal field of view by
//! default) at the vehicle's origin, looking along the body x axis tilted by the camera
//! tilt about body y (positive tilt looks up, like positive pitch; the control block's
//! tilt). Pixel (u, v) looks along `ned_from_body · Ry(tilt) · (1, (u−cx)/f, (v−cy)/f)`,
//! with the vehicle's ZYX attitude from `rov_dynamics` (Fossen): yaw turns the scene,
//! pitch tilts it, roll rolls it, diving approaches the seabed. [`SimCamera::project`]
//! is the same mapping the other way (tests check that landmarks land where it says).
//!
//! # Why these defaults
//! The built-in 20-s `topside record --sim` dive descends from the surface to 3 m and turns
//! from 000° to 090° with the lights off. With the seabed at 6 m and 8 m of visibility,
//! at the start the upper half is the bright rippled surface close above and the seabed is
//! lost in the haze; at 3 m the surface has dimmed and receded and the grid and markers
//! of the seabed fill the lower half, and the turn sweeps them (and the sun's side of the
//! surface) sideways. A test renders both ends of that dive and checks they differ.
//!
//! # Cost
//! One pass over the pixels with incremental ray directions, a table for the fog and
//! integer hashing for the texture: see `cargo bench -p rov_video --bench video`
//! (`simcam/render_640x480`, target ≤ 5 ms on one core).

use nalgebra::{Matrix3, Vector3};
use rov_dynamics::kinematics::Attitude;

use crate::error::{Result, VideoError};
use crate::frame::{VideoFrame, rgba_len};
use crate::stamp;

/// Refractive index of water (critical angle asin(1/n) = 48.6°).
const N_WATER: f64 = 1.333;
/// Entries of the fog table, covering 0..FOG_RANGE_VIS visibilities.
const FOG_TABLE: usize = 1024;
const FOG_RANGE_VIS: f32 = 8.0;
/// The camera never renders from above the surface or below the seabed (m of margin).
const MIN_CLEARANCE_M: f64 = 0.05;

/// The scene: seabed, landmarks, surface, water and lighting. Every field has a default
/// (see the module docs for why).
#[derive(Debug, Clone, PartialEq)]
pub struct SimScene {
    /// Seed of the landmark layout and textures.
    pub seed: u64,
    /// Depth of the flat seabed, m (0.5..=10000).
    pub seabed_depth_m: f64,
    /// Spacing of the seabed grid lines, m (> 0).
    pub grid_spacing_m: f64,
    /// Side of a landmark cell, m (> 0); each cell holds at most one landmark.
    pub landmark_cell_m: f64,
    /// Probability that a cell holds a landmark (0..=1).
    pub landmark_density: f64,
    /// Visibility with the lights off, m (> 0): the distance at which contrast falls to 1/e.
    pub visibility_m: f64,
    /// Visibility added by the lights at 100 %, m (≥ 0).
    pub lights_visibility_gain_m: f64,
    /// Depth over which daylight falls to 1/e, m (> 0).
    pub light_falloff_m: f64,
    /// Azimuth of the sun, degrees from north, clockwise.
    pub sun_azimuth_deg: f64,
    /// Elevation of the sun above the horizon, degrees (0..=90).
    pub sun_elevation_deg: f64,
}

impl Default for SimScene {
    fn default() -> Self {
        Self {
            seed: 1,
            seabed_depth_m: 6.0,
            grid_spacing_m: 2.0,
            landmark_cell_m: 3.0,
            landmark_density: 0.45,
            visibility_m: 8.0,
            lights_visibility_gain_m: 9.0,
            light_falloff_m: 10.0,
            sun_azimuth_deg: 135.0,
            sun_elevation_deg: 50.0,
        }
    }
}

impl SimScene {
    /// Checks every field's range.
    ///
    /// # Errors
    /// [`VideoError::InvalidConfig`] naming the field, its value and the allowed range.
    pub fn validate(&self) -> Result<()> {
        let check = |field: &'static str, v: f64, ok: bool, allowed: &'static str| {
            if v.is_finite() && ok {
                Ok(())
            } else {
                Err(VideoError::InvalidConfig {
                    field,
                    value: v.to_string(),
                    allowed,
                })
            }
        };
        check(
            "seabed_depth_m",
            self.seabed_depth_m,
            (0.5..=10_000.0).contains(&self.seabed_depth_m),
            "0.5..=10000 m",
        )?;
        check(
            "grid_spacing_m",
            self.grid_spacing_m,
            self.grid_spacing_m > 0.0,
            "> 0 m",
        )?;
        check(
            "landmark_cell_m",
            self.landmark_cell_m,
            self.landmark_cell_m >= 0.5,
            ">= 0.5 m",
        )?;
        check(
            "landmark_density",
            self.landmark_density,
            (0.0..=1.0).contains(&self.landmark_density),
            "0..=1",
        )?;
        check(
            "visibility_m",
            self.visibility_m,
            self.visibility_m > 0.0,
            "> 0 m",
        )?;
        check(
            "lights_visibility_gain_m",
            self.lights_visibility_gain_m,
            self.lights_visibility_gain_m >= 0.0,
            ">= 0 m",
        )?;
        check(
            "light_falloff_m",
            self.light_falloff_m,
            self.light_falloff_m > 0.0,
            "> 0 m",
        )?;
        check("sun_azimuth_deg", self.sun_azimuth_deg, true, "finite")?;
        check(
            "sun_elevation_deg",
            self.sun_elevation_deg,
            (0.0..=90.0).contains(&self.sun_elevation_deg),
            "0..=90 deg",
        )?;
        Ok(())
    }
}

/// The camera's image geometry.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CameraModel {
    /// Width, px.
    pub width_px: u32,
    /// Height, px.
    pub height_px: u32,
    /// Horizontal field of view, degrees (10..=170).
    pub hfov_deg: f64,
}

impl Default for CameraModel {
    fn default() -> Self {
        Self {
            width_px: 640,
            height_px: 480,
            hfov_deg: 75.0,
        }
    }
}

impl CameraModel {
    fn focal_px(&self) -> f64 {
        f64::from(self.width_px) * 0.5 / (self.hfov_deg.to_radians() * 0.5).tan()
    }
}

/// Where the camera is: the vehicle's pose (NED position of the body origin, ZYX Euler
/// angles as in Fossen) and the camera tilt.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct CameraPose {
    /// North, m.
    pub north_m: f64,
    /// East, m.
    pub east_m: f64,
    /// Depth (down), m.
    pub down_m: f64,
    /// Roll φ, rad (positive starboard down).
    pub roll_rad: f64,
    /// Pitch θ, rad (positive nose up).
    pub pitch_rad: f64,
    /// Yaw ψ, rad (0 = north, positive clockwise seen from above).
    pub yaw_rad: f64,
    /// Camera tilt about the body y axis, rad (positive looks up).
    pub tilt_rad: f64,
}

impl CameraPose {
    /// From the units of the telemetry and of `/truth/state`: metres and degrees.
    pub fn from_degrees(
        north_m: f64,
        east_m: f64,
        depth_m: f64,
        roll_deg: f64,
        pitch_deg: f64,
        heading_deg: f64,
        tilt_deg: f64,
    ) -> Self {
        Self {
            north_m,
            east_m,
            down_m: depth_m,
            roll_rad: roll_deg.to_radians(),
            pitch_rad: pitch_deg.to_radians(),
            yaw_rad: heading_deg.to_radians(),
            tilt_rad: tilt_deg.to_radians(),
        }
    }

    fn is_finite(&self) -> bool {
        [
            self.north_m,
            self.east_m,
            self.down_m,
            self.roll_rad,
            self.pitch_rad,
            self.yaw_rad,
            self.tilt_rad,
        ]
        .iter()
        .all(|v| v.is_finite())
    }

    /// NED from camera axes (forward, right, down).
    pub fn ned_from_camera(&self) -> Matrix3<f64> {
        let body = Attitude::new(self.roll_rad, self.pitch_rad, self.yaw_rad).ned_from_body();
        let (s, c) = self.tilt_rad.sin_cos();
        // Ry(tilt): positive tilt raises the optical axis (as positive pitch raises the nose).
        let tilt = Matrix3::new(c, 0.0, s, 0.0, 1.0, 0.0, -s, 0.0, c);
        body * tilt
    }
}

/// A landmark on the seabed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Landmark {
    /// Centre north, m.
    pub north_m: f64,
    /// Centre east, m.
    pub east_m: f64,
    /// Radius, m.
    pub radius_m: f64,
    /// Colour (linear 0..1).
    pub rgb: [f32; 3],
}

const PALETTE: [[f32; 3]; 5] = [
    [0.95, 0.25, 0.15], // red
    [1.00, 0.60, 0.10], // orange
    [0.95, 0.95, 0.90], // white
    [0.20, 0.80, 0.35], // green
    [0.95, 0.90, 0.20], // yellow
];

fn mix64(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

fn hash2(ix: i64, iy: i64, seed: u64) -> u64 {
    mix64(
        (ix as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15)
            ^ (iy as u64).wrapping_mul(0xC2B2_AE3D_27D4_EB4F)
            ^ seed,
    )
}

fn unit(h: u64, shift: u32) -> f64 {
    ((h >> shift) & 0xFFFF) as f64 / 65535.0
}

/// The renderer. Build once ([`SimCamera::new`]), render many frames.
#[derive(Debug, Clone)]
pub struct SimCamera {
    scene: SimScene,
    model: CameraModel,
    stamp_time: bool,
    fog: Vec<f32>,
    sun_dir_water: Vector3<f64>,
    cos_critical: f64,
}

impl SimCamera {
    /// A renderer for a scene and a camera. `stamp_time` draws the frame time into every
    /// frame ([`crate::stamp`]).
    ///
    /// # Errors
    /// [`VideoError::InvalidConfig`] for a scene field or camera size out of range.
    pub fn new(scene: SimScene, model: CameraModel, stamp_time: bool) -> Result<Self> {
        scene.validate()?;
        if !(16..=4096).contains(&model.width_px) || !(16..=4096).contains(&model.height_px) {
            return Err(VideoError::InvalidConfig {
                field: "camera size",
                value: format!("{}×{}", model.width_px, model.height_px),
                allowed: "16..=4096 px per side",
            });
        }
        if !(model.hfov_deg.is_finite() && (10.0..=170.0).contains(&model.hfov_deg)) {
            return Err(VideoError::InvalidConfig {
                field: "hfov_deg",
                value: model.hfov_deg.to_string(),
                allowed: "10..=170 deg",
            });
        }
        let fog = (0..FOG_TABLE)
            .map(|i| (-(i as f32) / FOG_TABLE as f32 * FOG_RANGE_VIS).exp())
            .collect();
        // The sun's rays refracted into the water: zenith angle shrinks by Snell's law.
        let zenith_air = (90.0 - scene.sun_elevation_deg).to_radians();
        let zenith_water = (zenith_air.sin() / N_WATER).asin();
        let az = scene.sun_azimuth_deg.to_radians();
        // Direction from the camera towards the sun (up is −z).
        let sun_dir_water = Vector3::new(
            zenith_water.sin() * az.cos(),
            zenith_water.sin() * az.sin(),
            -zenith_water.cos(),
        );
        let cos_critical = (1.0 - 1.0 / (N_WATER * N_WATER)).sqrt();
        Ok(Self {
            scene,
            model,
            stamp_time,
            fog,
            sun_dir_water,
            cos_critical,
        })
    }

    /// The scene.
    pub fn scene(&self) -> &SimScene {
        &self.scene
    }

    /// The camera model.
    pub fn model(&self) -> &CameraModel {
        &self.model
    }

    /// The landmark of the cell containing (north, east), if that cell has one.
    pub fn landmark_in_cell(&self, north_m: f64, east_m: f64) -> Option<Landmark> {
        let cell = self.scene.landmark_cell_m;
        let (ix, iy) = (
            (north_m / cell).floor() as i64,
            (east_m / cell).floor() as i64,
        );
        self.landmark_at(ix, iy)
    }

    fn landmark_at(&self, ix: i64, iy: i64) -> Option<Landmark> {
        let h = hash2(ix, iy, self.scene.seed);
        if unit(h, 0) >= self.scene.landmark_density {
            return None;
        }
        let cell = self.scene.landmark_cell_m;
        let radius_m = cell * (0.1 + 0.15 * unit(h, 16));
        let free = cell - 2.0 * radius_m;
        let north_m = ix as f64 * cell + radius_m + free * unit(h, 32);
        let east_m = iy as f64 * cell + radius_m + free * unit(h, 48);
        let rgb = PALETTE
            .get((mix64(h) % PALETTE.len() as u64) as usize)
            .copied()
            .unwrap_or([1.0; 3]);
        Some(Landmark {
            north_m,
            east_m,
            radius_m,
            rgb,
        })
    }

    /// Landmarks whose centres lie within `radius_m` of (north, east).
    pub fn landmarks_near(&self, north_m: f64, east_m: f64, radius_m: f64) -> Vec<Landmark> {
        let cell = self.scene.landmark_cell_m;
        let r = radius_m.clamp(0.0, 1000.0);
        let (i0, i1) = (
            ((north_m - r) / cell).floor() as i64,
            ((north_m + r) / cell).floor() as i64,
        );
        let (j0, j1) = (
            ((east_m - r) / cell).floor() as i64,
            ((east_m + r) / cell).floor() as i64,
        );
        let mut out = Vec::new();
        for i in i0..=i1 {
            for j in j0..=j1 {
                if let Some(l) = self.landmark_at(i, j)
                    && (l.north_m - north_m).hypot(l.east_m - east_m) <= r
                {
                    out.push(l);
                }
            }
        }
        out
    }

    fn camera_position(&self, pose: &CameraPose) -> Vector3<f64> {
        let down = pose
            .down_m
            .clamp(MIN_CLEARANCE_M, self.scene.seabed_depth_m - MIN_CLEARANCE_M);
        Vector3::new(pose.north_m, pose.east_m, down)
    }

    /// The pixel (u, v) where a NED point appears, `None` behind the camera. The inverse of
    /// the rendering's ray mapping.
    pub fn project(&self, pose: &CameraPose, point_ned: Vector3<f64>) -> Option<(f64, f64)> {
        let rel = pose.ned_from_camera().transpose() * (point_ned - self.camera_position(pose));
        if rel.x <= 1e-6 {
            return None;
        }
        let f = self.model.focal_px();
        let cx = f64::from(self.model.width_px) * 0.5;
        let cy = f64::from(self.model.height_px) * 0.5;
        Some((cx + f * rel.y / rel.x, cy + f * rel.z / rel.x))
    }

    /// Renders a new frame (see [`SimCamera::render_into`]); `t_ns` becomes its capture
    /// time (and its stamp when enabled).
    pub fn render(&self, pose: &CameraPose, lights_pct: f64, t_ns: u64, seq: u64) -> VideoFrame {
        let mut frame = VideoFrame {
            width_px: self.model.width_px,
            height_px: self.model.height_px,
            capture_ns: t_ns,
            seq,
            rgba: vec![0; rgba_len(self.model.width_px, self.model.height_px)],
        };
        self.render_into(pose, lights_pct, &mut frame);
        frame
    }

    /// Renders into an existing frame (resized if needed, no allocation otherwise). A pose
    /// with a non-finite value gives a black frame; lights are clamped to 0..100 %.
    pub fn render_into(&self, pose: &CameraPose, lights_pct: f64, frame: &mut VideoFrame) {
        let (w, h) = (self.model.width_px, self.model.height_px);
        let len = rgba_len(w, h);
        frame.width_px = w;
        frame.height_px = h;
        if frame.rgba.len() != len {
            frame.rgba.resize(len, 0);
        }
        if !pose.is_finite() {
            for px in frame.rgba.chunks_exact_mut(4) {
                px.copy_from_slice(&[0, 0, 0, 255]);
            }
            return;
        }
        let lights = if lights_pct.is_finite() {
            (lights_pct / 100.0).clamp(0.0, 1.0)
        } else {
            0.0
        };
        self.render_pixels(pose, lights, frame);
        if self.stamp_time {
            let t = frame.capture_ns;
            stamp::stamp_time(frame, t);
        }
    }

    #[allow(clippy::too_many_lines)]
    fn render_pixels(&self, pose: &CameraPose, lights: f64, frame: &mut VideoFrame) {
        let s = &self.scene;
        let m = pose.ned_from_camera();
        let cam = self.camera_position(pose);
        let f = self.model.focal_px();
        let (w, h) = (self.model.width_px as usize, self.model.height_px as usize);
        let cx = w as f64 * 0.5 - 0.5;
        let cy = h as f64 * 0.5 - 0.5;
        // Ray(u, v) = c0 + (u − cx)/f · c1 + (v − cy)/f · c2 (not normalised).
        let c0 = m.column(0).into_owned();
        let c1 = m.column(1).into_owned() / f;
        let c2 = m.column(2).into_owned() / f;
        let nose = Attitude::new(pose.roll_rad, pose.pitch_rad, pose.yaw_rad)
            .ned_from_body()
            .column(0)
            .into_owned();

        let depth = cam.z;
        let daylight = (-depth / s.light_falloff_m).exp() as f32;
        let vis = (s.visibility_m + lights * s.lights_visibility_gain_m) as f32;
        let fog_scale = FOG_TABLE as f32 / (FOG_RANGE_VIS * vis);
        // Beyond this distance the fog hides everything (transmission < 0.4 %).
        let max_dist = 5.5 * vis;
        let lights_f = lights as f32;
        let water_top = [0.16 * daylight, 0.42 * daylight, 0.50 * daylight];
        let water_bottom = [0.03 * daylight, 0.13 * daylight, 0.17 * daylight];
        let sand = [0.62f32, 0.56, 0.40];
        let seabed = s.seabed_depth_m as f32;
        let cam_f = [cam.x as f32, cam.y as f32, cam.z as f32];
        let grid = s.grid_spacing_m as f32;
        let inv_grid = 1.0 / grid;
        let inv_cell = (1.0 / s.landmark_cell_m) as f32;
        let pixel_angle = (1.0 / f) as f32;
        let sun = [
            self.sun_dir_water.x as f32,
            self.sun_dir_water.y as f32,
            self.sun_dir_water.z as f32,
        ];
        let cos_crit = self.cos_critical as f32;
        let nose_f = [nose.x as f32, nose.y as f32, nose.z as f32];
        // Daylight reaching the seabed (it travels down through the water).
        let seabed_daylight = (-s.seabed_depth_m / s.light_falloff_m).exp() as f32;
        let sky = daylight.max(0.15);
        let seed = s.seed;

        // The landmark lookup is cached per cell (neighbouring pixels mostly share one).
        let mut cached_cell: Option<(i64, i64, Option<Landmark>)> = None;

        let fog = |dist: f32| -> f32 {
            let i = (dist * fog_scale) as usize;
            self.fog.get(i).copied().unwrap_or(0.0)
        };
        let step = [c1.x as f32, c1.y as f32, c1.z as f32];

        for (v, row) in frame.rgba.chunks_exact_mut(w * 4).enumerate() {
            let dv = v as f64 - cy;
            let base = c0 + c2 * dv - c1 * cx;
            let mut d = [base.x as f32, base.y as f32, base.z as f32];
            for px in row.chunks_exact_mut(4) {
                let len2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
                let inv_len = 1.0 / len2.sqrt();
                let dz = d[2] * inv_len; // down component of the unit ray
                // Background water: lighter looking up, darker looking down.
                let up = (0.5 - 0.5 * dz).clamp(0.0, 1.0);
                let water = [
                    water_bottom[0] + (water_top[0] - water_bottom[0]) * up,
                    water_bottom[1] + (water_top[1] - water_bottom[1]) * up,
                    water_bottom[2] + (water_top[2] - water_bottom[2]) * up,
                ];
                let mut out = water;
                if dz > 1e-4 {
                    // Seabed.
                    let t = (seabed - cam_f[2]) / d[2];
                    let dist = t * len2 * inv_len;
                    if dist < max_dist {
                        let trans = fog(dist);
                        let pn = cam_f[0] + t * d[0];
                        let pe = cam_f[1] + t * d[1];
                        // Tile texture (0.5 m tiles).
                        let tile = hash2(floor_i64(pn * 2.0), floor_i64(pe * 2.0), seed);
                        let tex = 0.85 + 0.3 * ((tile & 0xFF) as f32 * (1.0 / 255.0));
                        let mut col = [sand[0] * tex, sand[1] * tex, sand[2] * tex];
                        // Grid lines, widened with distance so they never alias to nothing.
                        let half_w = (0.03f32).max(dist * pixel_angle * 0.75);
                        let gn = pn * inv_grid;
                        let ge = pe * inv_grid;
                        let on = (gn - round_f32(gn)).abs() * grid < half_w;
                        let oe = (ge - round_f32(ge)).abs() * grid < half_w;
                        if on || oe {
                            col = [0.10, 0.10, 0.12];
                        }
                        // Landmark of this cell.
                        let ci = floor_i64(pn * inv_cell);
                        let cj = floor_i64(pe * inv_cell);
                        let lm = match cached_cell {
                            Some((a, b, l)) if a == ci && b == cj => l,
                            _ => {
                                let l = self.landmark_at(ci, cj);
                                cached_cell = Some((ci, cj, l));
                                l
                            }
                        };
                        if let Some(l) = lm {
                            let dn = pn - l.north_m as f32;
                            let de = pe - l.east_m as f32;
                            let r2 = dn * dn + de * de;
                            let r = l.radius_m as f32;
                            if r2 < r * r {
                                let rim = r2 > (0.8 * r) * (0.8 * r);
                                col = if rim {
                                    [l.rgb[0] * 0.3, l.rgb[1] * 0.3, l.rgb[2] * 0.3]
                                } else {
                                    l.rgb
                                };
                            }
                        }
                        // Daylight from above plus the vehicle's lights along its nose.
                        let along =
                            (d[0] * nose_f[0] + d[1] * nose_f[1] + d[2] * nose_f[2]) * inv_len;
                        let spot = if along > 0.0 {
                            let a2 = along * along;
                            a2 * a2
                        } else {
                            0.0
                        };
                        let lamp = lights_f * 1.6 * spot / (1.0 + dist * dist * 0.04);
                        let light = (1.1 * seabed_daylight + lamp) * trans;
                        let keep = 1.0 - trans;
                        out = [
                            col[0] * light + water[0] * keep,
                            col[1] * light + water[1] * keep,
                            col[2] * light + water[2] * keep,
                        ];
                    }
                } else if dz < -1e-4 {
                    // Surface above.
                    let t = cam_f[2] / -d[2];
                    let dist = t * len2 * inv_len;
                    if dist < max_dist {
                        let trans = fog(dist);
                        let pn = cam_f[0] + t * d[0];
                        let pe = cam_f[1] + t * d[1];
                        // Two wave trains fixed in the world.
                        let ripple = 1.0
                            + 0.18 * fast_sin(pn * 2.6 + pe * 1.5) * fast_sin(pe * 3.1 - pn * 1.2);
                        let col = if -dz > cos_crit {
                            // Inside Snell's window: the sky, brightest towards the sun.
                            let c = (d[0] * sun[0] + d[1] * sun[1] + d[2] * sun[2]) * inv_len;
                            let glare = if c > 0.9 { (c - 0.9) * 10.0 } else { 0.0 };
                            let b = (0.75 + 0.9 * glare * glare) * ripple * sky;
                            [0.70 * b, 0.88 * b, 0.95 * b]
                        } else {
                            // Total reflection of the water below, lit by the ripples.
                            let b = 0.9 * ripple;
                            [
                                water_top[0] * b,
                                water_top[1] * b * 1.05,
                                water_top[2] * b * 1.05,
                            ]
                        };
                        let keep = 1.0 - trans;
                        out = [
                            col[0] * trans + water[0] * keep,
                            col[1] * trans + water[1] * keep,
                            col[2] * trans + water[2] * keep,
                        ];
                    }
                }
                px.copy_from_slice(&[to_u8(out[0]), to_u8(out[1]), to_u8(out[2]), 255]);
                d[0] += step[0];
                d[1] += step[1];
                d[2] += step[2];
            }
        }
    }
}

/// ⌊x⌋ without a libm call (x86-64 without SSE4.1 has no rounding instruction).
fn floor_i64(x: f32) -> i64 {
    let i = x as i64;
    if (i as f32) > x { i - 1 } else { i }
}

/// x rounded to the nearest integer (ties away from zero do not matter here).
fn round_f32(x: f32) -> f32 {
    floor_i64(x + 0.5) as f32
}

/// sin x to about 0.1 % (a parabola with one correction step), for the ripples.
fn fast_sin(x: f32) -> f32 {
    use std::f32::consts::{PI, TAU};
    let x = x - TAU * round_f32(x / TAU); // −π..π
    let y = (4.0 / PI) * x - (4.0 / (PI * PI)) * x * x.abs();
    0.225 * (y * y.abs() - y) + y
}

fn to_u8(x: f32) -> u8 {
    (x * 255.0).clamp(0.0, 255.0) as u8
}
