#!/usr/bin/python3
"""doppel's own GameController, driven through doppel-ctl and the control API, as a robot hears it.

A robot's listener on a loopback port receives the packets; each is compared byte for byte with a
golden packet built here by hand from the published header, in its field order and sizes
(include/RoboCupGameControlData.h of github.com/RoboCup-Humanoid-TC/GameController at
c7200dcf763c758951ae7516d577b117e16f9156, GAMECONTROLLER_STRUCT_VERSION 12, little-endian and
packed as that commit's Java GameControlData.toByteArray() writes it), not with Doppel's encoder.
Then: a return packet shows in /api/game; another GameController (played by this test on a
loopback port) makes doppel's step aside; doppel-ctl game on lets it send again; a bad request
names its field. Only loopback: every port is picked by the system.

usage: doppel_gamecontroller_test.py DOPPEL DOPPEL_CTL
"""
import json
import os
import re
import socket
import struct
import subprocess
import sys
import tempfile
import time

TEAM_A, TEAM_B = 5, 6


sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "support"))
from doppel_script_test import Api, Failure, check, script_test_main, stop_doppel  # noqa: E402


def golden(state, packet_number, kick_off=TEAM_A, penalties=(), scores=(0, 0)):
    """RoboCupGameControlData as the header lays it out; penalties: (team index, player, code, secs)."""
    b = b"RGme"                                      # 0  header
    b += struct.pack("<H", 12)                       # 4  version
    b += bytes([packet_number,                       # 6  packetNumber
                4,                                   # 7  playersPerTeam (doppel --gc-players default)
                0,                                   # 8  gameType: GAME_ROUNDROBIN
                state,                               # 9  state
                1,                                   # 10 firstHalf
                kick_off,                            # 11 kickOffTeam
                0])                                  # 12 secondaryState: STATE2_NORMAL
    b += bytes(4)                                    # 13 secondaryStateInfo[4]
    b += bytes([0])                                  # 17 dropInTeam
    b += struct.pack("<HHH", 0xFFFF, 600, 0)         # 18 dropInTime (-1 before the first), secsRemaining, secondaryTime
    for t, number in enumerate((TEAM_A, TEAM_B)):    # 24, 356 teams[2]
        b += bytes([number, t, scores[t], 0])        #    teamNumber, teamColour (cyan, magenta), score, penaltyShot
        b += struct.pack("<H", 0)                    #    singleShots
        b += bytes([0]) + bytes(253)                 #    coachSequence, coachMessage[SPL_COACH_MESSAGE_SIZE]
        b += bytes(6)                                #    coach (RobotInfo)
        for player in range(1, 12):                  #    players[MAX_NUM_PLAYERS]: penalty, secsTillUnpenalised,
            info = [0, 0, 0, 0, 0, 0]                #    numberOfWarnings, yellowCardCount, redCardCount, goalKeeper
            for team, p, code, secs in penalties:
                if team == t and p == player:
                    info[0], info[1] = code, secs
            b += bytes(info)
    check(len(b) == 688, f"the golden packet has {len(b)} bytes, the header's struct 688")
    return b


def next_packet(robot, state, what, tries=20):
    """The next packet in `state` (older ones may still be on their way)."""
    for _ in range(tries):
        data = robot.recv(2048)
        check(len(data) == 688, f"{what}: a {len(data)}-byte packet")
        if data[9] == state:
            return data
    raise Failure(f"{what}: no packet with state {state} in {tries}")


def ctl(doppel_ctl, url, links, *args):
    return subprocess.run([doppel_ctl, "--url", url.rstrip("/"), "--link-dir", links, *args],
                          capture_output=True, text=True, timeout=30)


def start_doppel(doppel, work, args):
    output_path = os.path.join(work, "doppel.txt")
    process = subprocess.Popen([doppel, "--physics", "none", "--no-camera", "--timing", "fast", "--viewer", "0",
                                "--link-dir", os.path.join(work, "links"), "--state-dir", os.path.join(work, "state"),
                                *args], stdout=open(output_path, "wb"), stderr=subprocess.STDOUT)
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline:
        text = open(output_path, encoding="utf-8", errors="replace").read()
        match = re.search(r"simulation control on (http://127\.0\.0\.1:\d+)/", text)
        if match:
            return process, match.group(1) + "/", output_path
        if process.poll() is not None:
            raise Failure(f"doppel exited ({process.returncode}):\n{text}")
        time.sleep(0.05)
    raise Failure("doppel did not start serving within 120 s")


def run(doppel, doppel_ctl):
    work = tempfile.mkdtemp(prefix="doppel-gc-test-")
    robot = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    robot.bind(("127.0.0.1", 0))
    robot.settimeout(5)
    process = None
    try:
        process, url, output_path = start_doppel(doppel, work, [
            "--gamecontroller", "--gc-teams", f"{TEAM_A},{TEAM_B}",
            "--gc-destination", f"127.0.0.1:{robot.getsockname()[1]}",
            "--gc-return", "127.0.0.1:0", "--gc-watch", "127.0.0.1:0"])
        links = os.path.join(work, "links")
        api = Api(url, links)

        # INITIAL, as the header lays it out.
        data = robot.recv(2048)
        check(data == golden(0, data[6]), f"the first packet differs from the header's INITIAL packet:\n{data.hex()}")

        # doppel-ctl game ready: READY reaches the robot.
        answer = ctl(doppel_ctl, url, links, "game", "ready")
        check(answer.returncode == 0, f"doppel-ctl game ready: {answer.returncode} {answer.stderr}")
        data = next_packet(robot, 1, "after doppel-ctl game ready")
        check(data == golden(1, data[6]), f"the READY packet differs from the header's:\n{data.hex()}")

        # A penalty through the API: player 2 of team B, physical contact (31), 30 s counting down.
        status, game = api("api/game", {"command": "penalize", "team": "B", "player": 2, "seconds": 30,
                                             "reason": "physical_contact"})
        check(status == 200, f"penalize: {status} {game}")
        check(game["teams"][1]["penalties"][0]["player"] == 2 and game["teams"][1]["penalties"][0]["penalty"] == 31,
              f"/api/game after the penalty: {game['teams']}")
        for _ in range(5):
            data = robot.recv(2048)
            offset = 356 + 266 + 6 * 1 + 1  # teams[1].players[1].secsTillUnpenalised
            if data[offset - 1] == 31:
                break
        secs = data[offset]
        check(28 <= secs <= 30, f"secsTillUnpenalised {secs}, 30 s were given a moment ago")
        check(data == golden(1, data[6], penalties=[(1, 2, 31, secs)]), f"the penalty packet differs:\n{data.hex()}")

        # The same through doppel-ctl: player 3 of team A (by its number), 20 s, service (35).
        answer = ctl(doppel_ctl, url, links, "game", "penalize", str(TEAM_A), "3", "20", "--reason", "service")
        check(answer.returncode == 0, f"doppel-ctl game penalize: {answer.returncode} {answer.stderr}")
        penalties = json.loads(answer.stdout)["teams"][0]["penalties"]
        check([(p["player"], p["penalty"], p["reason"]) for p in penalties] == [(3, 35, "service")],
              f"after doppel-ctl game penalize: {penalties}")
        answer = ctl(doppel_ctl, url, links, "game", "unpenalize", "A", "3")
        check(answer.returncode == 0 and not json.loads(answer.stdout)["teams"][0]["penalties"],
              f"doppel-ctl game unpenalize: {answer.stdout} {answer.stderr}")
        answer = ctl(doppel_ctl, url, links, "game", "goal", "B")
        check(answer.returncode == 1 and "goal is not allowed in READY" in answer.stderr, f"goal in READY: {answer.stderr}")

        # A robot's return packet ("RGrt", version 2, team, player, message 2 = alive) shows in /api/game.
        _, game = api("api/game")
        return_port = int(game["return_address"].rsplit(":", 1)[1])
        robot.sendto(b"RGrt" + bytes([2, TEAM_A, 1, 2]), ("127.0.0.1", return_port))
        deadline = time.monotonic() + 5
        while time.monotonic() < deadline and not api("api/game")[1]["returns"]:
            time.sleep(0.05)
        returns = api("api/game")[1]["returns"]
        check(returns and returns[0]["team"] == TEAM_A and returns[0]["player"] == 1 and returns[0]["message"] == "alive",
              f"the return packet is not in /api/game: {returns}")

        # A refused change: the game's reason; a bad request: its field; neither reaches the robot.
        answer = ctl(doppel_ctl, url, links, "game", "playing")
        check(answer.returncode == 1 and "not allowed in READY" in answer.stderr, f"playing in READY: {answer.stderr}")
        status, error = api("api/game", {"command": "penalize", "team": "B", "player": 12})
        check(status == 400 and "'player'" in error["error"], f"player 12: {status} {error}")
        status, error = api("api/game", {"command": "state", "state": "halftime"})
        check(status == 400 and "'state'" in error["error"], f"state halftime: {status} {error}")

        # Another GameController appears (this test plays it, on doppel's watch port): doppel's
        # stops sending and says so.
        watch_port = int(game["watch"].rsplit(":", 1)[1])
        foreign = bytearray(golden(3, 0))
        foreign[24], foreign[356] = 21, 22  # teams 21 and 22, PLAYING
        other = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        other.bind(("127.0.0.1", 0))
        other.sendto(bytes(foreign), ("127.0.0.1", watch_port))
        deadline = time.monotonic() + 5
        while time.monotonic() < deadline and api("api/game")[1]["sending"]:
            time.sleep(0.05)
        _, game = api("api/game")
        check(not game["sending"], "doppel's GameController still sends with another one on the network")
        check(f"127.0.0.1:{other.getsockname()[1]}" in game["stepped_aside"], f"stepped_aside: {game['stepped_aside']}")
        check(game["foreign"]["teams"] == [21, 22] and game["foreign"]["state"] == "playing", f"foreign: {game['foreign']}")
        robot.settimeout(0.3)
        try:
            while True:
                robot.recv(2048)  # what was on its way
        except socket.timeout:
            pass
        robot.settimeout(1.5)
        try:
            data = robot.recv(2048)
            raise Failure(f"a packet reached the robot after doppel stepped aside (state {data[9]})")
        except socket.timeout:
            pass
        log = open(output_path, encoding="utf-8", errors="replace").read()
        check("stopped sending" in log, f"doppel did not say it stepped aside:\n{log}")

        # doppel-ctl game on: it sends again, the game as it was.
        answer = ctl(doppel_ctl, url, links, "game", "on")
        check(answer.returncode == 0, f"doppel-ctl game on: {answer.stderr}")
        robot.settimeout(5)
        data = robot.recv(2048)
        check(data[:4] == b"RGme" and data[9] == 1, f"after game on: {data[:12].hex()}")
        answer = ctl(doppel_ctl, url, links, "game", "status")
        check(answer.returncode == 0 and json.loads(answer.stdout)["sending"], f"doppel-ctl game status: {answer.stdout}")
        other.close()
        print("doppel GameController test: passed")
    finally:
        robot.close()
        stop_doppel(process, work)


if __name__ == "__main__":
    sys.exit(script_test_main("doppel GameController test", __doc__, 2, run))
