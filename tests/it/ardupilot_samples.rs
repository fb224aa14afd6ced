//! Samples from ArduPilot boats (docs/learning.md, "From ArduPilot"): a
//! SITL boat runs a Lua script that reads a field at the boat's own
//! position and sends it with `gcs:send_named_float`, as a sensor on a
//! companion computer or a script would; the bridge (`--sample-name RISK`)
//! turns each into a sample at the boat's position on its link, and a
//! coordinator with `[learning]` learns from them. Checked: samples
//! arrive and are fitted, and the belief at the boat agrees with the
//! script's field there within 15 %. Needs ArduPilot's SITL binary as the
//! SITL tests do (skipped with a message without it, failing under
//! `CI=true`).

use std::time::Duration;

use serde_json::Value;

use crate::common::server::density_at;
use crate::common::sitl::{
    Bridge, Coordinator, ORIGIN, ardupilot, boat_with, mission_toml, one_sitl_fleet, place,
    wait_for,
};

/// The script's field: base 0.1 plus one Gaussian of α 10 and σ 25 m at
/// 30 m east and 20 m north of the mission's origin.
const CENTRE: (f64, f64) = (30.0, 20.0);

fn field(x: f64, y: f64) -> f64 {
    let d2 = (x - CENTRE.0).powi(2) + (y - CENTRE.1).powi(2);
    0.1 + 10.0 * (-d2 / (2.0 * 25.0 * 25.0)).exp()
}

/// The Lua sensor: twice a second, the field at the boat's position.
fn script() -> String {
    let (lat, lon) = crate::common::geo::place(ORIGIN, CENTRE.0, CENTRE.1);
    format!(
        r#"local centre = Location()
centre:lat({})
centre:lng({})
function update()
  local here = ahrs:get_location()
  if here then
    local d = here:get_distance(centre)
    gcs:send_named_float('RISK', 0.1 + 10.0 * math.exp(-d * d / (2.0 * 25.0 * 25.0)))
  end
  return update, 500
end
return update, 1000
"#,
        (lat * 1e7).round() as i64,
        (lon * 1e7).round() as i64
    )
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_lua_sensor_on_a_sitl_boat_is_learned_by_the_coordinator() {
    let Some(ap) = ardupilot() else { return };
    let _one = one_sitl_fleet().await;
    let dir = tempfile::tempdir().unwrap();
    let config = dir.path().join("mission.toml");
    std::fs::write(&config, mission_toml() + "\n[learning]\nrefit = 2.0\n").unwrap();
    let coordinator = Coordinator::start(&dir.path().join("data"), &config, "127.0.0.1:0");
    let base = format!("http://{}", coordinator.addr);
    let http = reqwest::Client::new();
    let lua = script();
    let b = boat_with(&ap, 1, place(70.0, 30.0), 45.0, Some(&lua));
    let args: Vec<String> = [
        "--server",
        &base,
        "--arm",
        "--sample-name",
        "RISK",
        "--sample-sd",
        "0.05",
        "--mavlink",
        &format!("tcpout:127.0.0.1:{}", b.primary),
    ]
    .map(String::from)
    .to_vec();
    let bridge = Bridge::agent(&args);
    let risk_url = format!("{base}/api/v1/risk");
    // Samples taken once the boat's poses are believed, fitted.
    let learned = wait_for(Duration::from_secs(90), async || {
        let r: Value = http.get(&risk_url).send().await.ok()?.json().await.ok()?;
        (r["source"] == "learned" && r["samples"].as_u64()? >= 20).then_some(r)
    })
    .await
    .unwrap_or_else(|| {
        panic!(
            "20 samples fitted within 90 s; the bridge said: {}",
            bridge
                .logged("")
                .iter()
                .map(|l| l["fields"].to_string())
                .collect::<Vec<_>>()
                .join("\n")
        )
    });
    let fitted_at = learned["fitted_at"].as_f64().unwrap();
    // The belief where the boat is (it samples where it goes), against
    // the script's field there.
    let vessels = coordinator.vessels(&http).await;
    let pose = vessels[0].pose.as_ref().expect("the boat has a pose");
    let (got, want) = (
        density_at(&learned["risk"], pose.x, pose.y),
        field(pose.x, pose.y),
    );
    println!(
        "{} samples, fitted at {fitted_at:.1} s; at the boat ({:.1}, {:.1}) the belief is {got:.3}, the script's field {want:.3}",
        learned["samples"], pose.x, pose.y
    );
    assert!(
        (got - want).abs() <= 0.15 * want,
        "belief {got} against the field's {want} at ({}, {})",
        pose.x,
        pose.y
    );
}
