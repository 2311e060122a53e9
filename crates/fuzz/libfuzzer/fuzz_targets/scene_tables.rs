#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| osw_fuzz::scene_tables::run(data));
