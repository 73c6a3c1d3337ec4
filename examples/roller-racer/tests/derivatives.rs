//! The derived constraint terms of the Roller Racer against finite
//! differences and dual numbers, at random states and parameters.

use crate::common;
use common::vehicle::RollerRacer;

#[test]
fn derived_terms_match_finite_differences_and_dual_numbers() {
    ezy::testing::assert_derivatives(&RollerRacer::default());
    // and a front axle behind a longer hinge arm
    ezy::testing::assert_derivatives(&RollerRacer { d2: 0.7, ..Default::default() });
}
