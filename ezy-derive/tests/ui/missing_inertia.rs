ezy_derive::model! {
    pub struct M {
        body one(x1, y1, phi1) { mass: 1.0 }
    }
}
fn main() {}
