ezy_derive::model! {
    pub struct M {
        param a = 1.0;
        body frame(x, y, phi) { mass: 1.0, inertia: 1.0 }
        point P on front at (a, 0);
    }
}
fn main() {}
