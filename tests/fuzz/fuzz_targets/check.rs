//! Parse and check arbitrary text: the front end must never panic, and every span it reports
//! must lie on character boundaries inside its file.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else { return };
    let compiled = revelio::check::compile("fuzz.rev", text, &revelio::check::std_only);
    for d in &compiled.diagnostics {
        if let Some(s) = d.span {
            let file = &compiled.files[s.file as usize].text;
            assert!(s.start <= s.end && s.end as usize <= file.len());
            assert!(file.is_char_boundary(s.start as usize) && file.is_char_boundary(s.end as usize));
        }
    }
});
