//! The teaching example runs as its header says, and writes what it says.

#[test]
fn linux_bus_without_a_device_shows_each_write() {
    let out = testkit::examples::run("orch-boards", "linux_bus", &[]);
    let mut want: Vec<String> = (0x21..=0x24)
        .flat_map(|a| {
            [
                format!("0x{a:02X}: [02, 00, 00]"),
                format!("0x{a:02X}: [06, 00, 00]"),
            ]
        })
        .collect();
    want.extend(["0x22: [02, 00, 01]".into(), "0x22: [02, 00, 00]".into()]);
    assert_eq!(out.lines().collect::<Vec<_>>(), want, "{out}");
}
