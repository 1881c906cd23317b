//! The scene model: triangles, a diffuse albedo and an emitted radiance per material, and a
//! camera. Nothing else until a scene needs it.

use glam::Vec3;

/// A diffuse material: reflectance and emitted radiance, linear RGB.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct Material {
    /// Diffuse albedo in [0, 1] per channel.
    pub albedo: [f32; 3],
    pub _pad0: f32,
    /// Emitted radiance (W sr^-1 m^-2 per channel); zero for non-emitters.
    pub emission: [f32; 3],
    pub _pad1: f32,
}

impl Material {
    pub const fn new(albedo: [f32; 3], emission: [f32; 3]) -> Self {
        Self {
            albedo,
            _pad0: 0.0,
            emission,
            _pad1: 0.0,
        }
    }

    /// Whether the material emits light.
    pub fn is_emissive(&self) -> bool {
        self.emission.iter().any(|&e| e > 0.0)
    }
}

/// One triangle: positions, optional per-vertex shading normals, and its material index.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Triangle {
    pub v: [Vec3; 3],
    pub n: Option<[Vec3; 3]>,
    pub material: u32,
}

impl Triangle {
    /// Geometric normal (unnormalized: its length is twice the area).
    pub fn cross(&self) -> Vec3 {
        (self.v[1] - self.v[0]).cross(self.v[2] - self.v[0])
    }
    /// Area of the triangle.
    pub fn area(&self) -> f32 {
        0.5 * self.cross().length()
    }
}

/// A pinhole camera.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Camera {
    pub eye: Vec3,
    pub target: Vec3,
    pub up: Vec3,
    /// Vertical field of view in degrees.
    pub vfov_deg: f32,
    pub width: u32,
    pub height: u32,
}

/// A scene ready to render: triangles with materials, and an optional camera from the file.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Scene {
    pub triangles: Vec<Triangle>,
    pub materials: Vec<Material>,
    pub camera: Option<Camera>,
}
