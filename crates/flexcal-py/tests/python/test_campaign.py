"""Campaign files from Python: `Campaign.read(path).run()` gives what
`flexcal.calibrate` gives with the same settings, writes the report with
the campaign in it, re-runs from that report; bad files raise FileError
naming the file and the key. The IPA UR10 C -> B campaign when the data is
present (skipped, with the reason, otherwise)."""

import json
import pathlib

import numpy as np
import pytest
from conftest import configurations, ipa_series

import flexcal


def simulated_set(ur10, path, n=60, seed=3):
    """A measured set of a UR10 whose link lengths are off by 0.3 mm,
    written to `path` (flexcal's CSV) and read back."""
    rng = np.random.default_rng(seed)
    truth = ur10.nominal + np.array(
        [3e-4 if p.unit == "m" else 0.0 for p in ur10.parameters]
    )
    q = configurations(ur10, n, seed=seed + 1)
    positions = ur10.fk(q, xi=truth)[:, :3, 3] + rng.normal(0.0, 20e-6, size=(n, 3))
    flexcal.MeasurementSet.from_arrays(q, positions).write_csv(path)
    return flexcal.MeasurementSet.read_csv(path)


CAMPAIGN = """
[robot]
name = "ur10"

[data]
files = ["../data/train.csv"]

[model]
fix = ["d2"]
select = "none"

[outputs]
report = "out/report.json"
"""


def test_a_campaign_runs_as_calibrate_does(ur10, tmp_path):
    (tmp_path / "data").mkdir()
    data = simulated_set(ur10, tmp_path / "data" / "train.csv")
    (tmp_path / "campaigns").mkdir()
    path = tmp_path / "campaigns" / "c.toml"
    path.write_text(CAMPAIGN)
    campaign = flexcal.Campaign.read(path)
    assert [pathlib.Path(p).name for p in campaign.data] == ["train.csv"]
    result = campaign.run()
    direct = flexcal.calibrate(ur10, data, fix=["d2"], select="none")
    assert result.after.position_rms == direct.after.position_rms
    assert result.identified == direct.identified
    assert result.identified["d2"] == ur10.nominal[ur10.parameter_names.index("d2")]
    # The report of the campaign's outputs carries the campaign.
    report = json.loads((tmp_path / "campaigns" / "out" / "report.json").read_text())
    assert report["config"]["data"]["files"] == ["../../data/train.csv"]
    assert report["config"]["model"]["fix"] == ["d2"]
    assert report["identification"]["position_rms_mm"] == pytest.approx(
        result.after.position_rms * 1e3, rel=1e-12
    )
    # ... and re-runs from it to the same figures.
    again = flexcal.Campaign.from_report(tmp_path / "campaigns" / "out" / "report.json")
    assert again.run(write_outputs=False).identified == result.identified
    # Written elsewhere, the paths follow the file's folder.
    campaign.write(tmp_path / "copy.toml")
    assert 'files = ["data/train.csv"]' in (tmp_path / "copy.toml").read_text()
    assert flexcal.Campaign.read(tmp_path / "copy.toml").to_toml(tmp_path) == (
        tmp_path / "copy.toml"
    ).read_text()


@pytest.mark.parametrize(
    "text, expected",
    [
        (CAMPAIGN + "\n[checks]\nsplitt = true\n", ["c.toml:16", "checks.splitt", "unknown field"]),
        (CAMPAIGN.replace("train.csv", "missing.csv"), ["c.toml", "data.files[0]", "names no file"]),
        (CAMPAIGN.replace("../data/train.csv", "sub/.."), ["data.files[0]", "leaves no file name"]),
        (CAMPAIGN.replace('select = "none"', "select = 3"), ["c.toml:10", "model.select"]),
    ],
)
def test_bad_campaign_files_raise_file_errors_naming_the_key(ur10, tmp_path, text, expected):
    (tmp_path / "data").mkdir()
    simulated_set(ur10, tmp_path / "data" / "train.csv", n=10)
    (tmp_path / "campaigns").mkdir()
    path = tmp_path / "campaigns" / "c.toml"
    path.write_text(text)
    with pytest.raises(flexcal.FileError) as error:
        flexcal.Campaign.read(path)
    message = str(error.value)
    assert "\n" not in message
    for part in expected:
        assert part in message, message


def test_ipa_c_to_b_campaign_gives_the_command_line_figures(tmp_path):
    series_b = ipa_series("Series_B", "measurements_joint_configurations.csv")
    series_c = ipa_series("Series_C", "measurements_random_poses.csv")
    path = tmp_path / "ipa.toml"
    path.write_text(
        f'[robot]\nname = "ur10"\n[data]\nfiles = ["{series_c}"]\nformat = "ipa"\n'
        f'[validation]\nfile = "{series_b}"\n[outputs]\nreport = "report.json"\n'
    )
    result = flexcal.Campaign.read(path).run()
    ur10 = flexcal.Robot.builtin("ur10")
    direct = flexcal.calibrate(ur10, flexcal.MeasurementSet.read_csv(series_c, format="ipa"))
    assert result.identified == direct.identified
    report = json.loads((tmp_path / "report.json").read_text())
    validation = direct.validate(flexcal.MeasurementSet.read_csv(series_b, format="ipa"))
    assert report["validation"]["position_mean_mm"] == pytest.approx(
        validation.after.position_mean * 1e3, rel=1e-12
    )
    print(f"IPA C -> B campaign: validation mean {report['validation']['position_mean_mm']:.4f} mm")
