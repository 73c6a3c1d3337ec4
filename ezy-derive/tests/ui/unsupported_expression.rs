ezy_derive::model! {
    pub struct M {
        param a = 1.0;
        body one(x1, y1, phi1) { mass: 1.0, inertia: 1.0 }
        point P on one at (a.abs(), tan(a));
    }
}
fn main() {}
