//! The pinhole camera: OpenGL look-at, looking down -Z of its frame, full vertical fov.

use glam::Vec3;

#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Camera {
    pub position: Vec3,
    /// Unit vectors of the camera frame in world space.
    pub forward: Vec3,
    pub right: Vec3,
    pub up: Vec3,
    /// tan(yfov / 2).
    pub tan_half_fov: f32,
}

impl Camera {
    /// # Panics (debug)
    /// `look_at != position` and `up` not parallel to the view direction (checked at the
    /// scene-file boundary).
    pub fn look_at(position: Vec3, look_at: Vec3, up: Vec3, yfov_deg: f32) -> Self {
        let forward = (look_at - position).normalize();
        Self::from_frame(position, forward, up, yfov_deg.to_radians())
    }

    /// From a position, a view direction, an approximate up vector and yfov in radians.
    pub fn from_frame(position: Vec3, forward: Vec3, up: Vec3, yfov_rad: f32) -> Self {
        let forward = forward.normalize();
        let right = forward.cross(up).normalize();
        debug_assert!(right.is_finite());
        let up = right.cross(forward);
        Self { position, forward, right, up, tan_half_fov: (0.5 * yfov_rad).tan() }
    }

    /// Unnormalised direction of the ray through raster position (x, y) of a width x height
    /// image, with (0, 0) the top-left corner (pixel centres at +0.5).
    #[inline]
    pub fn ray_direction(&self, x: f32, y: f32, width: u32, height: u32) -> Vec3 {
        let aspect = width as f32 / height as f32;
        let ndc_x = 2.0 * x / width as f32 - 1.0;
        let ndc_y = 1.0 - 2.0 * y / height as f32;
        self.forward
            + (ndc_x * self.tan_half_fov * aspect) * self.right
            + (ndc_y * self.tan_half_fov) * self.up
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::{Mat4, Vec4};

    /// gluLookAt, written out from its manual page: rows s, u, -f, then a translation by -eye.
    fn glu_look_at(eye: Vec3, center: Vec3, up: Vec3) -> Mat4 {
        let f = (center - eye).normalize();
        let s = f.cross(up).normalize();
        let u = s.cross(f);
        let rotation = Mat4::from_cols(
            Vec4::new(s.x, u.x, -f.x, 0.0),
            Vec4::new(s.y, u.y, -f.y, 0.0),
            Vec4::new(s.z, u.z, -f.z, 0.0),
            Vec4::W,
        );
        rotation * Mat4::from_translation(-eye)
    }

    /// gluPerspective, written out from its manual page (fovy in degrees).
    fn glu_perspective(fovy_deg: f32, aspect: f32, near: f32, far: f32) -> Mat4 {
        let f = 1.0 / (fovy_deg.to_radians() * 0.5).tan();
        Mat4::from_cols(
            Vec4::new(f / aspect, 0.0, 0.0, 0.0),
            Vec4::new(0.0, f, 0.0, 0.0),
            Vec4::new(0.0, 0.0, (far + near) / (near - far), -1.0),
            Vec4::new(0.0, 0.0, 2.0 * far * near / (near - far), 0.0),
        )
    }

    #[test]
    fn world_point_lands_on_the_pixel_the_gl_matrices_predict() {
        let (w, h) = (320u32, 200u32);
        let eye = Vec3::new(1.2, 0.9, 1.4);
        let target = Vec3::new(0.0, 0.35, 0.0);
        let fov = 40.0f32;
        let cam = Camera::look_at(eye, target, Vec3::Y, fov);
        let view = glu_look_at(eye, target, Vec3::Y);
        let proj = glu_perspective(fov, w as f32 / h as f32, 0.01, 100.0);
        let points =
            [Vec3::new(0.1, 0.2, -0.3), Vec3::new(-0.4, 0.6, 0.2), Vec3::new(0.25, 0.0, 0.25), target];
        for world in points {
            let clip = proj * view * Vec4::from((world, 1.0));
            let ndc = clip.truncate() / clip.w;
            let px = (ndc.x + 1.0) * 0.5 * w as f32;
            let py = (1.0 - ndc.y) * 0.5 * h as f32;
            // The ray through that raster point passes through the world point.
            let d = cam.ray_direction(px, py, w, h).normalize();
            let to_point = (world - eye).normalize();
            assert!(d.cross(to_point).length() < 2e-6, "{world}: {d} vs {to_point}");
            // And the pixel is the one whose centre ray is closest to the point.
            let (ix, iy) = (px.floor(), py.floor());
            let centre = cam.ray_direction(ix + 0.5, iy + 0.5, w, h).normalize();
            let angle_px = 2.0 * cam.tan_half_fov / h as f32;
            assert!(centre.cross(to_point).length() < 0.75 * angle_px, "{world}");
        }
        // The look-at target is the image centre.
        let d = cam.ray_direction(w as f32 * 0.5, h as f32 * 0.5, w, h).normalize();
        assert!(d.cross((target - eye).normalize()).length() < 2e-6);
    }
}
