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
/// Side of the seabed tile texture table (tiles of 0.5 m: it repeats every 32 m).
const TEX_SIDE: usize = 64;
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

/// A landmark as the renderer needs it, in f32.
#[derive(Debug, Clone, Copy)]
struct Disc {
    north_m: f32,
    east_m: f32,
    r2: f32,
    inner_r2: f32,
    rgb: [f32; 3],
    rim: [f32; 3],
}

impl Disc {
    fn of(l: Landmark) -> Self {
        let r = l.radius_m as f32;
        let [red, green, blue] = l.rgb;
        Self {
            north_m: l.north_m as f32,
            east_m: l.east_m as f32,
            r2: r * r,
            inner_r2: (0.8 * r) * (0.8 * r),
            rgb: l.rgb,
            rim: [red * 0.3, green * 0.3, blue * 0.3],
        }
    }
}

/// The renderer. Build once ([`SimCamera::new`]), render many frames.
#[derive(Debug, Clone)]
pub struct SimCamera {
    scene: SimScene,
    model: CameraModel,
    stamp_time: bool,
    fog: Vec<f32>,
    /// Brightness factor of each seabed tile (0.85..1.15), from the seed.
    texture: Vec<f32>,
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
        let texture = (0..TEX_SIDE * TEX_SIDE)
            .map(|i| {
                let h = hash2(
                    (i / TEX_SIDE) as i64,
                    (i % TEX_SIDE) as i64,
                    scene.seed ^ 0x7E47,
                );
                0.85 + 0.3 * ((h & 0xFF) as f32 / 255.0)
            })
            .collect();
        Ok(Self {
            scene,
            model,
            stamp_time,
            fog,
            texture,
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
        // Beyond this distance the fog hides everything (transmission < 1 %: under one
        // level of 8-bit colour at these brightnesses).
        let max_dist = 4.6 * vis;
        let lights_f = lights as f32;
        let water_top = [0.16 * daylight, 0.42 * daylight, 0.50 * daylight];
        let water_bottom = [0.03 * daylight, 0.13 * daylight, 0.17 * daylight];
        let sand = [0.62f32, 0.56, 0.40];
        let seabed = s.seabed_depth_m as f32;
        let cam_f = [cam.x as f32, cam.y as f32, cam.z as f32];
        let grid = s.grid_spacing_m as f32;
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

        // The landmark lookup is cached per cell (neighbouring pixels mostly share one):
        // centre, radius² of the disc and of its bright inside, colour.
        let mut cached_cell: Option<(f32, f32, Option<Disc>)> = None;

        let step = [c1.x as f32, c1.y as f32, c1.z as f32];
        let setup = TraceSetup {
            cam: cam_f,
            seabed,
            nose: nose_f,
            sun,
            fog_scale,
            grid_m: grid,
            inv_cell,
        };
        let mut rays = RowRays::new(w);

        for (v, row) in frame.rgba.chunks_exact_mut(w * 4).enumerate() {
            let dv = v as f64 - cy;
            let base = c0 + c2 * dv - c1 * cx;
            rays.trace([base.x as f32, base.y as f32, base.z as f32], step, &setup);
            let [out_r, out_g, out_b] = &mut rays.rgb;
            let per_pixel = out_r
                .iter_mut()
                .zip(out_g.iter_mut().zip(out_b.iter_mut()))
                .zip(rays.dz.iter().zip(rays.dist.iter()))
                .zip(rays.pn.iter().zip(rays.pe.iter()))
                .zip(rays.lamp.iter().zip(rays.sun.iter()))
                .zip(rays.fog_index.iter().zip(rays.tile.iter()))
                .zip(rays.cell_n.iter().zip(rays.cell_e.iter()))
                .zip(rays.grid_m.iter().zip(rays.ripple.iter()));
            for (
                (
                    ((((px, (&dz, &dist)), (&pn, &pe)), (&lamp_unit, &sun_cos)), (&fog_i, &tile)),
                    (&ci, &cj),
                ),
                (&grid_off, &ripple),
            ) in per_pixel
            {
                // Background water: lighter looking up, darker looking down.
                let up = (0.5 - 0.5 * dz).clamp(0.0, 1.0);
                let water = [
                    water_bottom[0] + (water_top[0] - water_bottom[0]) * up,
                    water_bottom[1] + (water_top[1] - water_bottom[1]) * up,
                    water_bottom[2] + (water_top[2] - water_bottom[2]) * up,
                ];
                let mut out = water;
                if dz > 1e-4 && dist < max_dist {
                    // Seabed.
                    // `as` saturates (NaN → 0): degenerate rays give in-range indices.
                    let trans = self.fog.get(fog_i as usize).copied().unwrap_or(0.0);
                    let tex = self.texture.get(tile as usize).copied().unwrap_or(1.0);
                    let mut col = [sand[0] * tex, sand[1] * tex, sand[2] * tex];
                    // Grid lines, widened with distance so they never alias to nothing.
                    if grid_off < (0.03f32).max(dist * pixel_angle * 0.75) {
                        col = [0.10, 0.10, 0.12];
                    }
                    // Landmark of this cell.
                    let lm = match cached_cell {
                        Some((a, b, l)) if a == ci && b == cj => l,
                        _ => {
                            let l = self.landmark_at(ci as i64, cj as i64).map(Disc::of);
                            cached_cell = Some((ci, cj, l));
                            l
                        }
                    };
                    if let Some(l) = lm {
                        let dn = pn - l.north_m;
                        let de = pe - l.east_m;
                        let r2 = dn * dn + de * de;
                        if r2 < l.r2 {
                            col = if r2 > l.inner_r2 { l.rim } else { l.rgb };
                        }
                    }
                    // Daylight from above plus the vehicle's lights along its nose.
                    let light = (1.1 * seabed_daylight + lights_f * lamp_unit) * trans;
                    let keep = 1.0 - trans;
                    out = [
                        col[0] * light + water[0] * keep,
                        col[1] * light + water[1] * keep,
                        col[2] * light + water[2] * keep,
                    ];
                } else if dz < -1e-4 && dist < max_dist {
                    // Surface above.
                    let trans = self.fog.get(fog_i as usize).copied().unwrap_or(0.0);
                    let col = if -dz > cos_crit {
                        // Inside Snell's window: the sky, brightest towards the sun.
                        let glare = if sun_cos > 0.9 {
                            (sun_cos - 0.9) * 10.0
                        } else {
                            0.0
                        };
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
                let (r, (g, b)) = px;
                (*r, *g, *b) = (out[0], out[1], out[2]);
            }
            rays.store(row);
        }
    }
}

/// The rays of one image row, traced in a branch-free pass the compiler vectorises:
/// the unit ray's down component, the distance to the seabed (looking down) or the
/// surface (looking up), the hit point with its fog-table index, texture tile, landmark
/// cell, distance to the nearest grid line and surface ripple, and the cosines to the
/// vehicle's nose and the sun. The shading pass then only looks things up.
struct RowRays {
    dz: Vec<f32>,
    dist: Vec<f32>,
    pn: Vec<f32>,
    pe: Vec<f32>,
    along: Vec<f32>,
    sun: Vec<f32>,
    fog_index: Vec<f32>,
    tile: Vec<f32>,
    cell_n: Vec<f32>,
    cell_e: Vec<f32>,
    grid_m: Vec<f32>,
    ripple: Vec<f32>,
    /// The lights' beam on the seabed point per unit of lights: cos⁴ off the nose over
    /// (1 + (d / 5 m)²).
    lamp: Vec<f32>,
    /// The shaded colour, before conversion to bytes.
    rgb: [Vec<f32>; 3],
}

/// What [`RowRays::trace`] needs of the scene and the pose, in f32.
#[derive(Clone, Copy)]
struct TraceSetup {
    cam: [f32; 3],
    seabed: f32,
    nose: [f32; 3],
    sun: [f32; 3],
    fog_scale: f32,
    grid_m: f32,
    inv_cell: f32,
}

impl RowRays {
    fn new(w: usize) -> Self {
        Self {
            dz: vec![0.0; w],
            dist: vec![0.0; w],
            pn: vec![0.0; w],
            pe: vec![0.0; w],
            along: vec![0.0; w],
            sun: vec![0.0; w],
            fog_index: vec![0.0; w],
            tile: vec![0.0; w],
            cell_n: vec![0.0; w],
            cell_e: vec![0.0; w],
            grid_m: vec![0.0; w],
            ripple: vec![0.0; w],
            lamp: vec![0.0; w],
            rgb: [vec![0.0; w], vec![0.0; w], vec![0.0; w]],
        }
    }

    /// Pixel u looks along `base + u · step` (NED, not normalised).
    fn trace(&mut self, base: [f32; 3], step: [f32; 3], k: &TraceSetup) {
        let below = k.seabed - k.cam[2];
        let above = -k.cam[2];
        let inv_grid = 1.0 / k.grid_m;
        let geometry = self
            .dz
            .iter_mut()
            .zip(self.dist.iter_mut())
            .zip(self.pn.iter_mut().zip(self.pe.iter_mut()))
            .zip(self.along.iter_mut().zip(self.sun.iter_mut()));
        for (u, (((dz, dist), (pn, pe)), (along, sun_cos))) in geometry.enumerate() {
            let uf = u as f32;
            let dx = base[0] + uf * step[0];
            let dy = base[1] + uf * step[1];
            let dd = base[2] + uf * step[2];
            let len = (dx * dx + dy * dy + dd * dd).sqrt();
            let inv = 1.0 / len;
            let t = if dd > 0.0 { below } else { above } / dd;
            *dz = dd * inv;
            *dist = t * len;
            *pn = k.cam[0] + t * dx;
            *pe = k.cam[1] + t * dy;
            *along = (dx * k.nose[0] + dy * k.nose[1] + dd * k.nose[2]) * inv;
            *sun_cos = (dx * k.sun[0] + dy * k.sun[1] + dd * k.sun[2]) * inv;
        }
        let lookups = self
            .fog_index
            .iter_mut()
            .zip(self.tile.iter_mut())
            .zip(self.cell_n.iter_mut().zip(self.cell_e.iter_mut()))
            .zip(self.grid_m.iter_mut().zip(self.ripple.iter_mut()))
            .zip(self.pn.iter().zip(self.pe.iter()).zip(self.dist.iter()));
        for ((((fog, tile), (cn, ce)), (grid, ripple)), ((&pn, &pe), &dist)) in lookups {
            // Float-only arithmetic (no conversions), so this loop vectorises too.
            *fog = (dist * k.fog_scale).min(FOG_TABLE as f32);
            let ti = floor_f(pn * 2.0);
            let tj = floor_f(pe * 2.0);
            let side = TEX_SIDE as f32;
            let mi = ti - side * floor_f(ti * (1.0 / side));
            let mj = tj - side * floor_f(tj * (1.0 / side));
            *tile = mi * side + mj;
            *cn = floor_f(pn * k.inv_cell);
            *ce = floor_f(pe * k.inv_cell);
            let gn = pn * inv_grid;
            let ge = pe * inv_grid;
            let off_n = (gn - round_f(gn)).abs();
            let off_e = (ge - round_f(ge)).abs();
            *grid = off_n.min(off_e) * k.grid_m;
            // Two wave trains fixed in the world.
            *ripple = 1.0 + 0.18 * fast_sin(pn * 2.6 + pe * 1.5) * fast_sin(pe * 3.1 - pn * 1.2);
        }
        for ((lamp, &along), &dist) in self
            .lamp
            .iter_mut()
            .zip(self.along.iter())
            .zip(self.dist.iter())
        {
            let a = along.max(0.0);
            let a2 = a * a;
            *lamp = 1.6 * a2 * a2 / (1.0 + dist * dist * 0.04);
        }
    }

    /// Writes the shaded colours of the row as RGBA bytes (a loop that vectorises).
    fn store(&self, row: &mut [u8]) {
        let [r, g, b] = &self.rgb;
        for (px, ((&r, &g), &b)) in row
            .chunks_exact_mut(4)
            .zip(r.iter().zip(g.iter()).zip(b.iter()))
        {
            px.copy_from_slice(&[to_u8(r), to_u8(g), to_u8(b), 255]);
        }
    }
}

/// 1.5 · 2²³: adding and subtracting it rounds an f32 to the nearest integer (ties to
/// even) for |x| < 2²², with plain float arithmetic that vectorises (x86-64 without
/// SSE4.1 has no rounding instruction, and a float → int cast saturates in Rust).
const ROUND_MAGIC: f32 = 12_582_912.0;

/// x rounded to the nearest integer (|x| < 2²²; larger values come back unchanged or
/// off by one, which only shifts a texture).
fn round_f(x: f32) -> f32 {
    (x + ROUND_MAGIC) - ROUND_MAGIC
}

/// ⌊x⌋ (same range as [`round_f`]).
fn floor_f(x: f32) -> f32 {
    let r = round_f(x);
    if r > x { r - 1.0 } else { r }
}

/// sin x to about 0.1 % (a parabola with one correction step), for the ripples.
fn fast_sin(x: f32) -> f32 {
    use std::f32::consts::{PI, TAU};
    let x = x - TAU * round_f(x * (1.0 / TAU)); // −π..π
    let y = (4.0 / PI) * x - (4.0 / (PI * PI)) * x * x.abs();
    0.225 * (y * y.abs() - y) + y
}

/// 0..1 to 0..255 (`as` saturates: below 0 → 0, above → 255, NaN → 0).
fn to_u8(x: f32) -> u8 {
    (x * 255.0) as u8
}
