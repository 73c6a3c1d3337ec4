ezy_derive::model! {
    pub struct M {
        body frame(x, y, phi) { mass: 0.0, inertia: -2 }
    }
}
fn main() {}
