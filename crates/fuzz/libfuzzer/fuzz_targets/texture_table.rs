#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| osw_fuzz::texture_table::run(data));
