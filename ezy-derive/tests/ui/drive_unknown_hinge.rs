ezy_derive::model! {
    pub struct M {
        body one(x1, y1, phi1) { mass: 1.0, inertia: 1.0 }
        body two(x2, y2, phi2) { mass: 1.0, inertia: 1.0 }
        point P on one at (1, 0);
        point Q on two at (-1, 0);
        hinge H: P = Q;
        drive D: hinge K;
        drive H: hinge H;
    }
}
fn main() {}
