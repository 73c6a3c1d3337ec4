ezy_derive::model! {
    pub struct M {
        param a = 1.0;
        body frame(x, y, phi) { mass: m, inertia: 1.0 }
        point P on frame at (-b, 0);
    }
}
fn main() {}
