//! Cross-crate scenarios of the topside workspace. The scenarios are the `[[test]]` files
//! beside this one; this library is empty.
