// Families: every reference error is reported at once, at its token.
ezy_derive::model! {
    pub struct M {
        count N = 4;
        param l = 1.0;
        body base(xb, yb, phib) { mass: 1.0, inertia: 1.0 }
        point H on base at (0, 0);
        for i in 0..N {
            body link[i](x, y, phi) { mass: 1.0, inertia: 0.1 }
            point F[i] on link[i] at (l, 0);
            point B[i] on link[i] at (-l, 0);
            // a family point must sit on the element of the same index
            point W[i] on link[i + 1] at (0, 0);
            // a family without an index
            skate S[i]: F along (1, 0);
        }
        for i in 1..K {
            // a single item with an index, and an unknown count above
            hinge J[i]: B[i - 1] = H[i];
        }
        // a drive drives one single hinge, not a family
        drive D: hinge J;
    }
}
fn main() {}
