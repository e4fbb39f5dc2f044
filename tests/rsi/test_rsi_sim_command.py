"""``feedopt rsi-sim`` as a user runs it against a streamer, and its bad inputs."""

import numpy as np
import pytest

from feedopt.cli import main
from feedopt.export.rsi import read_rsi_csv
from feedopt.rsi.corrections import plan_from_table
from feedopt.rsi.streamer import Streamer, StreamSettings, StreamStatus
from tests.rsi.test_stream import OWN_LATE, _in_thread


def test_rsi_sim_against_the_streamer(stretch, tmp_path, capsys) -> None:
    csv = stretch(300)
    plan = plan_from_table(read_rsi_csv(csv), 0.004, csv.name)
    log = tmp_path / "sim.csv"
    box: dict = {}
    with Streamer(StreamSettings(listen=("127.0.0.1", 0), wait_s=10.0,
                                 late_after_s=OWN_LATE)) as streamer:
        thread = _in_thread(box, "report", lambda: streamer.run(plan))
        port = streamer.address[1]
        code = main(["rsi-sim", "--connect", f"127.0.0.1:{port}", "--reference", str(csv),
                     "--compliance-mm", "0.1,0,0", "--lag-ms", "8", "--log", str(log)])
        thread.join(10.0)
    out = capsys.readouterr().out
    assert code == 0, out
    assert box["report"].status is StreamStatus.COMPLETED
    assert "rsi-sim stopped by the sensor" in out
    # the plant: 8 ms lag behind the command, true TCP 0.1 mm off in x
    lines = log.read_text().splitlines()
    names = lines[0].split(",")
    data = np.array([[float(v) for v in line.split(",")] for line in lines[1:]])
    col = {n: data[:, i] for i, n in enumerate(names)}
    np.testing.assert_allclose(col["true_x"] - col["encoder_x"], 0.1, atol=1e-9)
    alpha = -np.expm1(-4.0 / 8.0)  # exact first-order lag over one 4 ms cycle
    prev = np.concatenate([[col["encoder_x"][0]], col["encoder_x"][:-1]])
    # encoder[k] = encoder[k-1] + alpha (command[k] - encoder[k-1]), from the first move on
    moving = slice(10, None)
    np.testing.assert_allclose(col["encoder_x"][moving], (prev + alpha * (
        col["command_x"] - prev))[moving], atol=1e-5)
    assert "true TCP from the reference path: max" in out


@pytest.mark.parametrize("argv, fragment", [
    (["--connect", "49152"], "give HOST:PORT"),
    (["--connect", "127.0.0.1:0"], "give the port feedopt stream listens on"),
    (["--compliance-mm", "0.1,0"], "--compliance-mm: expected 3 comma-separated numbers"),
    (["--lag-ms", "-1"], "--lag-ms must be >= 0"),
    (["--cycle-ms", "5"], "RSI runs 4 or 12 ms cycles"),
    (["--start-pose", "1,2,3,4,5,6", "--reference", "x.csv"], "not both"),
])
def test_bad_input(argv, fragment, capsys) -> None:
    assert main(["rsi-sim", *argv]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("feedopt rsi-sim: error: ") and fragment in err[0]


def test_timeout_when_nobody_answers(capsys) -> None:
    import socket

    quiet = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)  # bound, never answers
    quiet.bind(("127.0.0.1", 0))
    try:
        code = main(["rsi-sim", "--connect", f"127.0.0.1:{quiet.getsockname()[1]}",
                     "--timeout-cycles", "20"])
    finally:
        quiet.close()
    assert code == 3
    assert "rsi-sim RSI timeout: 20 cycles, 20 late answers" in capsys.readouterr().out
