ezy_derive::model! {
    pub struct M {
        body frame(x, y, phi) { mass: 1.0, inertia: 1.0 }
        point P on frame at (0, 0);
        skate P: P along (0, 0.0);
    }
}
fn main() {}
