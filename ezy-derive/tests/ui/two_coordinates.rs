ezy_derive::model! {
    pub struct M {
        body one(x1, y1) { mass: 1.0, inertia: 1.0 }
    }
}
fn main() {}
