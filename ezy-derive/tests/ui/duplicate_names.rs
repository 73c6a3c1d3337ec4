ezy_derive::model! {
    pub struct M {
        param a = 1.0;
        param a = 2.0;
        body frame(x, y, phi) { mass: 1.0, inertia: 1.0 }
        body fork(x, y2, phi2) { mass: 1.0, inertia: 1.0 }
    }
}
fn main() {}
