#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| osw_fuzz::path_csv::run(data));
