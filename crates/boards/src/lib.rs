//! Finger-board drivers (being written).
#![no_std]
