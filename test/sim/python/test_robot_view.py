# SPDX-License-Identifier: GPL-3.0-or-later
"""The dashboard's 3D view of a robot (`ax12-emu serve --robot arm --dashboard`, docs/dashboard.md)
in a real headless Chromium (Debian's, through Selenium; WebGL on SwiftShader, the CPU's
renderer): the page draws the robot; its picture changes when DynamixelSDK moves a servo over
the pty, and when a link is clicked (its servo selected and highlighted); the page's world
changes (a payload, gravity, a push) reach the running robot, read back through the control
socket. Screenshots are kept in $AX12_ARTIFACT_DIR (build/test-artifacts)."""
import io
import os
import time

import dynamixel_sdk as sdk
import numpy as np
import pytest
from PIL import Image
from selenium.common.exceptions import TimeoutException
from selenium.webdriver.common.action_chains import ActionChains
from selenium.webdriver.common.by import By
from selenium.webdriver.support.ui import Select

import ax12_control
import ax12_table as T
from test_dashboard import ARTIFACTS, free_port, headless_chromium, message, open_port, retried, wait_for

# Chromium without a GPU draws WebGL with SwiftShader; these make it do so whatever the build's
# default (Debian's Chromium also does without them).
WEBGL_FLAGS = ("--use-angle=swiftshader", "--enable-unsafe-swiftshader")
CHANGED_LEVEL = 40      # a pixel changed: a channel moved by more than this (0..255)
DARK_LEVEL = 90         # the AX-12's black case and the arm's base, lit: every channel below this


@pytest.fixture
def browser():
    driver = headless_chromium("--window-size=1400,1000", *WEBGL_FLAGS)
    yield driver
    driver.quit()


def canvas_image(driver, name=None):
    """The 3D view as an array of RGB pixels (a screenshot of its element); kept as
    robot-view-NAME.png when named. A screenshot that times out on a loaded machine is taken
    again."""
    for attempt in range(3):
        try:
            png = driver.find_element(By.ID, "robot-view").screenshot_as_png
            break
        except TimeoutException:
            if attempt == 2:
                raise
    if name:
        os.makedirs(ARTIFACTS, exist_ok=True)
        with open(os.path.join(ARTIFACTS, "robot-view-%s.png" % name), "wb") as f:
            f.write(png)
    return np.asarray(Image.open(io.BytesIO(png)).convert("RGB")).astype(int)


def changed_share(a, b):
    """The share of the pixels that changed between two pictures of the view."""
    assert a.shape == b.shape
    return float((np.abs(a - b).max(axis=2) > CHANGED_LEVEL).mean())


def dark_share(image):
    return float((image.max(axis=2) < DARK_LEVEL).mean())


def status(tmp_path):
    with ax12_control.Control(ax12_control.default_socket_path(str(tmp_path))) as control:
        return control.request("status")


def signed(value):
    return (value & 0x3FF) * (-1 if value & 0x400 else 1)


def servo_load(tmp_path, slot):
    return signed(next(s for s in status(tmp_path)["servos"] if s["slot"] == slot)["present_load"])


def physics_time(driver):
    """The physics' time the page shows ("physics t = 12.34 s; ...")."""
    text = driver.find_element(By.ID, "robot-now").text
    return float(text.split("=")[1].split()[0]) if text.startswith("physics t =") else -1.0


def page_caught_up(driver, tmp_path):
    """Waits until the page has drawn a pose from after now (the emulator's physics time)."""
    now = status(tmp_path)["robot"]["time_s"]
    wait_for(lambda: physics_time(driver) > now + 0.2, 15, "the page's pose to pass t = %.2f s" % now)
    time.sleep(0.3)  # its frame drawn


def test_the_3d_view_draws_the_robot_and_follows_servos_and_world_changes(emulator, browser, tmp_path):
    port_number = free_port()
    emu = emulator("--realtime", "--robot", "arm", "--state-dir", str(tmp_path), "--dashboard", str(port_number))
    port, handler = open_port(emu.device)
    try:
        browser.get("http://127.0.0.1:%d/" % port_number)
        wait_for(lambda: browser.find_element(By.ID, "connection").text == "live", 15, "the page to go live")
        wait_for(lambda: browser.find_element(By.ID, "robot").is_displayed(), 10, "the robot's section")
        assert browser.find_element(By.ID, "robot-name").text == "arm"
        wait_for(lambda: browser.execute_script("return state.robotView && state.robotView.frames > 0"), 20,
                 "the 3D view's first frame")

        # Every servo holds its joint at angle 0: the arm stands straight up, and the picture
        # stays the same from one second to the next.
        for slot in range(1, 6):
            assert retried(handler.write2ByteTxRx, port, slot, T.GOAL_POSITION, 512) == (sdk.COMM_SUCCESS, 0)
            assert retried(handler.write1ByteTxRx, port, slot, T.TORQUE_ENABLE, 1) == (sdk.COMM_SUCCESS, 0)
        time.sleep(1.0)
        page_caught_up(browser, tmp_path)
        first = canvas_image(browser)
        time.sleep(1.0)
        page_caught_up(browser, tmp_path)
        upright = canvas_image(browser, "1-upright")
        assert dark_share(upright) > 0.003, "the robot's black servo cases are not drawn"
        assert changed_share(first, upright) < 0.001

        # A goal over the bus leans the arm forward: the picture changes.
        assert retried(handler.write2ByteTxRx, port, 2, T.GOAL_POSITION, 712) == (sdk.COMM_SUCCESS, 0)

        def shoulder_arrived():
            position, result, _ = retried(handler.read2ByteTxRx, port, 2, T.PRESENT_POSITION)
            return result == sdk.COMM_SUCCESS and abs(position - 712) <= 20
        wait_for(shoulder_arrived, 10, "the shoulder at Goal 712")
        time.sleep(0.5)  # settled
        page_caught_up(browser, tmp_path)
        leaning = canvas_image(browser, "2-leaning")
        assert changed_share(upright, leaning) > 0.01, "the view did not follow the shoulder's move"
        assert dark_share(leaning) > 0.003

        # A click on the forearm selects servo 3 (its elbow) and highlights it instead of servo 1.
        point = browser.execute_script(
            "return state.robotView.screenPoint(state.robot.bodies.findIndex((b) => b.name === 'forearm'))")
        canvas = browser.find_element(By.CSS_SELECTOR, "#robot-view canvas")
        size = canvas.size
        ActionChains(browser).move_to_element_with_offset(
            canvas, int(point["x"] - size["width"] / 2), int(point["y"] - size["height"] / 2)).click().perform()
        wait_for(lambda: browser.find_element(By.ID, "selected-name").text.startswith("3"), 5, "servo 3 selected")
        time.sleep(0.5)
        selected = canvas_image(browser, "3-elbow-selected")
        assert changed_share(leaning, selected) > 0.002, "the elbow's highlight is not drawn"

        # A payload from the page: on the arm's tip, read back from the emulator, and the
        # shoulder holding more.
        load_before = servo_load(tmp_path, 2)
        Select(browser.find_element(By.ID, "robot-payload-body")).select_by_value("grip")
        kg = browser.find_element(By.ID, "robot-payload-kg")
        kg.clear()
        kg.send_keys("0.3")
        browser.find_element(By.ID, "robot-payload-apply").click()
        wait_for(lambda: "the robot's world changed" in message(browser), 5, "the payload's answer")
        assert status(tmp_path)["robot"]["world"]["payloads"] == [{"body": "grip", "kg": 0.3}]
        wait_for(lambda: abs(servo_load(tmp_path, 2)) > abs(load_before) + 40, 5,
                 "the shoulder's Present Load rising with the payload (was %d)" % load_before)
        # Refused whole by the emulator, with its message; nothing changes.
        kg.clear()
        kg.send_keys("20")
        browser.find_element(By.ID, "robot-payload-apply").click()
        wait_for(lambda: "0..10 kg" in message(browser), 5, "the refusal of 20 kg")
        assert "bad" in browser.find_element(By.ID, "message").get_attribute("class")
        assert status(tmp_path)["robot"]["world"]["payloads"] == [{"body": "grip", "kg": 0.3}]

        # Gravity off from the page, then a push on the hand with the base's torque off: the
        # base turns the leaning arm about the vertical (the hand's pose, read back).
        browser.find_element(By.ID, "robot-gravity").click()
        wait_for(lambda: status(tmp_path)["robot"]["world"]["gravity"] is False, 5, "gravity off")
        assert retried(handler.write1ByteTxRx, port, 1, T.TORQUE_ENABLE, 0) == (sdk.COMM_SUCCESS, 0)
        robot = browser.execute_script("return state.robot")
        hand = [b["name"] for b in robot["bodies"]].index("hand")
        hand_before = status(tmp_path)["robot"]["poses"][hand]
        Select(browser.find_element(By.ID, "robot-push-body")).select_by_value("hand")
        for field, value in (("robot-push-x", "0"), ("robot-push-y", "5"), ("robot-push-z", "0"), ("robot-push-s", "0.2")):
            box = browser.find_element(By.ID, field)
            box.clear()
            box.send_keys(value)
        browser.find_element(By.ID, "robot-push-apply").click()
        wait_for(lambda: "push" in message(browser) and "world changed" in message(browser), 5, "the push's answer")
        wait_for(lambda: abs(status(tmp_path)["robot"]["poses"][hand][1] - hand_before[1]) > 0.01, 5,
                 "the pushed hand moving sideways")
        browser.find_element(By.ID, "robot-gravity").click()
        wait_for(lambda: status(tmp_path)["robot"]["world"]["gravity"] is True, 5, "gravity on again")
        page_caught_up(browser, tmp_path)
        assert browser.find_element(By.ID, "robot-gravity").is_selected()
        assert "gravity on; payloads: grip 0.3 kg" in browser.find_element(By.ID, "robot-now").text
        canvas_image(browser, "4-pushed")
    finally:
        port.closePort()


SHAPES_MODEL = """<mujoco model="shapes">
  <compiler angle="degree" autolimits="true"/>
  <custom><numeric name="ax12:spin" data="1"/></custom>
  <default><geom contype="0" conaffinity="0"/></default>
  <asset>
    <mesh name="tetra" vertex="0 0 0  0.06 0 0  0 0.06 0  0 0 0.06" face="0 2 1  0 1 3  0 3 2  1 2 3"/>
  </asset>
  <worldbody>
    <geom name="floor" type="plane" size="0 0 0.05" rgba="0.85 0.85 0.82 1"/>
    <geom name="box" type="box" size="0.03 0.03 0.03" pos="-0.15 0 0.03" rgba="1 0 0 1"/>
    <geom name="sphere" type="sphere" size="0.03" pos="-0.05 0 0.03" rgba="0 1 0 1"/>
    <geom name="capsule" type="capsule" size="0.02 0.03" pos="0.05 0 0.05" rgba="0 0 1 1"/>
    <geom name="cylinder" type="cylinder" size="0.03 0.02" pos="0.15 0 0.02" rgba="1 1 0 1"/>
    <geom name="ellipsoid" type="ellipsoid" size="0.04 0.02 0.015" pos="-0.1 0.12 0.015" rgba="1 0 1 1"/>
    <geom name="mesh" type="mesh" mesh="tetra" pos="0.05 0.1 0" rgba="0 1 1 1"/>
    <geom name="hidden" type="box" size="0.2 0.2 0.2" pos="0 0 0.2" group="3" rgba="1 0 0 1"/>
    <body name="rotor" pos="0 -0.12 0.05">
      <joint name="spin" type="hinge" axis="0 0 1" range="-150 150"/>
      <geom name="rotor_bar" type="box" size="0.05 0.008 0.008" mass="0.05" rgba="0.5 0.5 0.5 1"/>
    </body>
  </worldbody>
</mujoco>
"""
SHAPE_COLOURS = {"box": (1, 0, 0), "sphere": (0, 1, 0), "capsule": (0, 0, 1), "cylinder": (1, 1, 0),
                 "ellipsoid": (1, 0, 1), "mesh": (0, 1, 1)}


def pixels_of_colour(image, rgb):
    """Pixels of a pure colour (each channel full or none: red, yellow...) under any light."""
    brightest = image.max(axis=2)
    share = image / np.maximum(brightest, 1)[..., None]
    full, none = share > 0.7, share < 0.3
    pattern = np.array(rgb, bool)
    return int(((brightest > 50) & (full | none).all(axis=2) & (full == pattern).all(axis=2)).sum())


def test_every_geom_type_is_drawn_in_its_colour_and_hidden_groups_are_not(emulator, browser, tmp_path):
    """A model of one geom of each type MuJoCo draws, each its own pure colour, on an infinite
    floor (size 0), and a large box of the same red as the small one in group 3 (hidden): each
    colour on the canvas, the red no more than the small box's."""
    model = tmp_path / "shapes.xml"
    model.write_text(SHAPES_MODEL)
    port_number = free_port()
    emulator("--realtime", "--robot", str(model), "--state-dir", str(tmp_path), "--dashboard", str(port_number))
    browser.get("http://127.0.0.1:%d/" % port_number)
    wait_for(lambda: browser.execute_script("return state.robotView && state.robotView.frames > 0"), 20,
             "the 3D view's first frame")
    time.sleep(0.5)
    image = canvas_image(browser, "shapes")
    drawn = {name: pixels_of_colour(image, rgb) for name, rgb in SHAPE_COLOURS.items()}
    assert all(count > 300 for count in drawn.values()), drawn
    assert drawn["box"] < 0.05 * image.shape[0] * image.shape[1], "the hidden box is drawn"
    floor = (np.abs(image - np.array([216, 216, 209])).max(axis=2) < 30).mean()
    assert floor > 0.2, "the floor is not drawn"
