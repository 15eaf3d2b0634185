"""Generate the sim's assets from the numbers in ``nodes/sim/robot_model.py``.

    .venv/bin/python sim_assets/make_assets.py          # rewrites the files below

* ``ur10e_2f85.urdf``: the UR10e from its published DH parameters (one URDF link frame per
  DH joint, so the URDF's forward kinematics *is* the DH chain), UR's link masses and centres
  of mass, box/cylinder collision geometry, and a 2F-85-class parallel gripper on the flange
  with two prismatic, force-limited fingers and a ``tcp`` link between the fingertips.
* ``block.obj``: a unit-free 50.8 mm cube with UVs: the top face maps onto the tag square of
  a block texture, the sides onto a plain wood patch of the same texture.
* ``tags/tag36h11_NNN.png``: one texture per tag id, drawn from OpenCV's
  ``DICT_APRILTAG_36h11`` (40.0 mm black square, 5.4 mm white margin, 5 px per mm).

Everything is deterministic: running it twice produces identical files.
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))

from nodes.robot import gripper_2f85 as g85  # noqa: E402
from nodes.robot import ur10e  # noqa: E402
from nodes.sim import robot_model as rm  # noqa: E402

N_TAGS = 50
PX_PER_MM = 5
TEXTURE_W, TEXTURE_H = 512, 256
WOOD_RGB = (205, 170, 120)
ARM_RGBA = {"blue": "0.55 0.70 0.85 1", "grey": "0.80 0.80 0.82 1", "dark": "0.15 0.15 0.15 1"}


# --- URDF ------------------------------------------------------------------------------------
def _fmt(values) -> str:
    return " ".join(f"{v:.10g}" for v in values)


def _box_inertia(mass: float, size) -> tuple[float, float, float]:
    x, y, z = size
    return (mass * (y * y + z * z) / 12, mass * (x * x + z * z) / 12, mass * (x * x + y * y) / 12)


def _inertial(mass: float, com, box) -> str:
    ixx, iyy, izz = _box_inertia(mass, box)
    return (f'    <inertial><origin xyz="{_fmt(com)}" rpy="0 0 0"/><mass value="{mass:.6g}"/>'
            f'<inertia ixx="{ixx:.6g}" ixy="0" ixz="0" iyy="{iyy:.6g}" iyz="0" izz="{izz:.6g}"/>'
            "</inertial>\n")


def _shape(kind: str, dims, xyz, rpy=(0, 0, 0), color: str = "blue", collide: bool = True) -> str:
    if kind == "box":
        geometry = f'<box size="{_fmt(dims)}"/>'
    else:
        geometry = f'<cylinder radius="{dims[0]:.6g}" length="{dims[1]:.6g}"/>'
    origin = f'<origin xyz="{_fmt(xyz)}" rpy="{_fmt(rpy)}"/>'
    out = (f'    <visual>{origin}<geometry>{geometry}</geometry>'
           f'<material name="{color}"><color rgba="{ARM_RGBA[color]}"/></material></visual>\n')
    if collide:
        out += f"    <collision>{origin}<geometry>{geometry}</geometry></collision>\n"
    return out


HALF_PI = math.pi / 2
ALONG_X = (0, HALF_PI, 0)  # cylinder axis (z) turned onto x
ALONG_Y = (HALF_PI, 0, 0)

# Primitive geometry per link, in the URDF link frame L_i = F_{i-1} Rz(q_i) (z = joint axis).
# The UR's sideways offsets (shoulder 176 mm, elbow back 137 mm ...) sum to d4 in the DH
# model; the tubes below sit at those offsets so the body looks and collides like a UR10e.
LINK_SHAPES: dict[str, list[str]] = {
    "base_link": [_shape("cylinder", (0.095, 0.06), (0, 0, 0.03), color="grey")],
    "shoulder_link": [
        _shape("cylinder", (0.075, 0.115), (0, 0, 0.1807 - 0.0575)),
        _shape("cylinder", (0.075, 0.15), (0, -0.085, 0.1807), ALONG_Y, "grey"),
    ],
    "upper_arm_link": [
        _shape("cylinder", (0.06, 0.50), (-0.6127 / 2, 0, 0.176), ALONG_X, "grey"),
        _shape("cylinder", (0.075, 0.12), (-0.6127, 0, 0.12), color="blue"),
    ],
    "forearm_link": [
        _shape("cylinder", (0.045, 0.48), (-0.57155 / 2, 0, 0.045), ALONG_X, "grey"),
        _shape("cylinder", (0.047, 0.09), (-0.57155, 0, 0.09), color="blue"),
    ],
    "wrist_1_link": [_shape("cylinder", (0.046, 0.10), (0, -0.04, 0.17415), ALONG_Y, "blue")],
    "wrist_2_link": [_shape("cylinder", (0.046, 0.10), (0, 0.04, 0.11985), ALONG_Y, "blue")],
    "wrist_3_link": [_shape("cylinder", (0.045, 0.045), (0, 0, 0.11655 - 0.0225), color="dark")],
}
LINK_INERTIA_BOX = {
    "shoulder_link": (0.15, 0.15, 0.20),
    "upper_arm_link": (0.70, 0.12, 0.15),
    "forearm_link": (0.62, 0.09, 0.10),
    "wrist_1_link": (0.09, 0.12, 0.09),
    "wrist_2_link": (0.09, 0.12, 0.09),
    "wrist_3_link": (0.09, 0.09, 0.05),
}
ARM_LINKS = tuple(LINK_INERTIA_BOX)


def _com_in_link_frame(i: int) -> np.ndarray:
    """UR gives centres of mass in DH frame i; URDF link i sits at F_{i-1} Rz(q_i)."""
    ca, sa = math.cos(ur10e.DH_ALPHA[i]), math.sin(ur10e.DH_ALPHA[i])
    rot_x = np.array([[1, 0, 0], [0, ca, -sa], [0, sa, ca]])
    return np.array([ur10e.DH_A[i], 0.0, ur10e.DH_D[i]]) + rot_x @ np.array(ur10e.LINK_COM_DH[i])


def _link(name: str, body: str) -> str:
    return f'  <link name="{name}">\n{body}  </link>\n'


def _joint(name: str, kind: str, parent: str, child: str, xyz, rpy, axis=None, limit="") -> str:
    out = (f'  <joint name="{name}" type="{kind}"><parent link="{parent}"/>'
           f'<child link="{child}"/><origin xyz="{_fmt(xyz)}" rpy="{_fmt(rpy)}"/>')
    if axis is not None:
        out += f'<axis xyz="{_fmt(axis)}"/>'
    return out + limit + "</joint>\n"


def arm_urdf() -> str:
    parts = ['<?xml version="1.0"?>\n',
             "<!-- Generated by sim_assets/make_assets.py from nodes/sim/robot_model.py. -->\n",
             '<robot name="ur10e_2f85">\n',
             _link("base_link", _inertial(4.0, (0, 0, 0.03), (0.19, 0.19, 0.06))
                   + "".join(LINK_SHAPES["base_link"]))]
    parent = "base_link"
    for i, (joint, link) in enumerate(zip(ur10e.ARM_JOINTS, ARM_LINKS, strict=True)):
        xyz = (0, 0, 0) if i == 0 else (ur10e.DH_A[i - 1], 0, ur10e.DH_D[i - 1])
        rpy = (0, 0, 0) if i == 0 else (ur10e.DH_ALPHA[i - 1], 0, 0)
        limit = (f'<limit lower="{-ur10e.JOINT_LIMIT:.6g}" upper="{ur10e.JOINT_LIMIT:.6g}" '
                 f'effort="{ur10e.JOINT_TORQUE_LIMIT[i]:.6g}" '
                 f'velocity="{ur10e.JOINT_VELOCITY_LIMIT[i]:.6g}"/>'
                 '<dynamics damping="0.0" friction="0.0"/>')
        parts.append(_joint(joint, "revolute", parent, link, xyz, rpy, (0, 0, 1), limit))
        body = _inertial(ur10e.LINK_MASS[i], _com_in_link_frame(i), LINK_INERTIA_BOX[link])
        parts.append(_link(link, body + "".join(LINK_SHAPES[link])))
        parent = link
    parts.append(_joint("flange_joint", "fixed", parent, "tool0",
                        (ur10e.DH_A[5], 0, ur10e.DH_D[5]), (ur10e.DH_ALPHA[5], 0, 0)))
    parts.append(_link("tool0", _inertial(0.001, (0, 0, 0), (0.01, 0.01, 0.01))))
    parts.append(gripper_urdf())
    parts.append("</robot>\n")
    return "".join(parts)


def gripper_urdf() -> str:
    """2F-85-class gripper in the flange frame (z out of the flange, x = closing axis)."""
    coupling = 0.011
    body_h = g85.TCP_OFFSET - g85.FINGER_LENGTH - coupling
    body_mass = g85.GRIPPER_MASS - 2 * g85.FINGER_MASS
    body = (_inertial(body_mass, (0, 0, coupling + body_h / 2), (0.12, 0.06, body_h))
            + _shape("cylinder", (0.0375, coupling), (0, 0, coupling / 2), color="dark")
            + _shape("box", (0.125, 0.060, body_h), (0, 0, coupling + body_h / 2), color="dark"))
    parts = [_joint("gripper_mount", "fixed", "tool0", "gripper_body", (0, 0, 0), (0, 0, 0)),
             _link("gripper_body", body)]
    finger_box = (rm.FINGER_THICKNESS, rm.FINGER_WIDTH, g85.FINGER_LENGTH)
    for joint, side in zip(rm.FINGER_JOINTS, (-1, 1), strict=True):
        link = joint.replace("_joint", "")
        centre = (side * rm.FINGER_THICKNESS / 2, 0, g85.FINGER_LENGTH / 2)
        limit = (f'<limit lower="0" upper="{rm.GRIPPER_STROKE / 2:.6g}" '
                 f'effort="{g85.GRIP_FORCE_RANGE[1]:.6g}" '
                 f'velocity="{g85.CLOSING_SPEED_RANGE[1] / 2:.6g}"/>')
        parts.append(_joint(joint, "prismatic", "gripper_body", link,
                            (0, 0, g85.TCP_OFFSET - g85.FINGER_LENGTH), (0, 0, 0), (side, 0, 0),
                            limit))
        parts.append(_link(link, _inertial(g85.FINGER_MASS, centre, finger_box)
                           + _shape("box", finger_box, centre, color="dark")))
    parts.append(_joint("tcp_joint", "fixed", "gripper_body", "tcp",
                        (0, 0, g85.TCP_OFFSET), (0, 0, 0)))
    parts.append(_link("tcp", _inertial(0.001, (0, 0, 0), (0.01, 0.01, 0.01))))
    return "".join(parts)


# --- block mesh and tag textures -------------------------------------------------------------
FACE_PX = round(rm.BLOCK_SIZE * 1000 * PX_PER_MM)  # 254 px: the top face in the texture


def block_obj() -> str:
    """A cube of side s centred at the origin; top face UVs -> tag square, sides -> wood."""
    h = rm.BLOCK_SIZE / 2
    u_top, v_top = FACE_PX / TEXTURE_W, 1.0 - FACE_PX / TEXTURE_H
    # (normal, four corners counter-clockwise seen from outside, their UVs)
    wood = [(0.70, 0.30), (0.90, 0.30), (0.90, 0.70), (0.70, 0.70)]
    faces = [
        ((0, 0, 1), [(-h, -h, h), (h, -h, h), (h, h, h), (-h, h, h)],
         [(0, v_top), (u_top, v_top), (u_top, 1), (0, 1)]),
        ((0, 0, -1), [(-h, h, -h), (h, h, -h), (h, -h, -h), (-h, -h, -h)], wood),
        ((1, 0, 0), [(h, -h, -h), (h, h, -h), (h, h, h), (h, -h, h)], wood),
        ((-1, 0, 0), [(-h, h, -h), (-h, -h, -h), (-h, -h, h), (-h, h, h)], wood),
        ((0, 1, 0), [(h, h, -h), (-h, h, -h), (-h, h, h), (h, h, h)], wood),
        ((0, -1, 0), [(-h, -h, -h), (h, -h, -h), (h, -h, h), (-h, -h, h)], wood),
    ]
    lines = ["# 2-inch block, generated by sim_assets/make_assets.py (metres)"]
    vt_lines, vn_lines, f_lines = [], [], []
    for k, (normal, corners, uvs) in enumerate(faces):
        lines += [f"v {x:.6f} {y:.6f} {z:.6f}" for x, y, z in corners]
        vt_lines += [f"vt {u:.6f} {v:.6f}" for u, v in uvs]
        vn_lines.append(f"vn {normal[0]} {normal[1]} {normal[2]}")
        a, b, c, d = (4 * k + j + 1 for j in range(4))
        n = k + 1
        f_lines += [f"f {a}/{a}/{n} {b}/{b}/{n} {c}/{c}/{n}",
                    f"f {a}/{a}/{n} {c}/{c}/{n} {d}/{d}/{n}"]
    return "\n".join(lines + vt_lines + vn_lines + f_lines) + "\n"


def tag_texture(tag_id: int) -> np.ndarray:
    """RGB texture: the top face (tag + white margin) top-left, plain wood elsewhere."""
    import cv2

    dictionary = cv2.aruco.getPredefinedDictionary(cv2.aruco.DICT_APRILTAG_36h11)
    cells = cv2.aruco.generateImageMarker(dictionary, tag_id, 8)  # 6x6 data + 1-cell border
    cell_px = round(rm.TAG_SIZE * 1000 * PX_PER_MM / 8)  # 25 px = 5 mm
    tag = np.kron(cells, np.ones((cell_px, cell_px), dtype=np.uint8))
    margin = round(rm.TAG_MARGIN * 1000 * PX_PER_MM)  # 27 px = 5.4 mm
    assert tag.shape[0] + 2 * margin == FACE_PX
    image = np.empty((TEXTURE_H, TEXTURE_W, 3), dtype=np.uint8)
    image[:] = WOOD_RGB
    image[:FACE_PX, :FACE_PX] = 255
    image[margin:margin + tag.shape[0], margin:margin + tag.shape[1]] = tag[..., None]
    return image


def main() -> int:
    import cv2

    (HERE / "ur10e_2f85.urdf").write_text(arm_urdf())
    (HERE / "block.obj").write_text(block_obj())
    tags = HERE / "tags"
    tags.mkdir(exist_ok=True)
    for tag_id in range(N_TAGS):
        image = tag_texture(tag_id)
        cv2.imwrite(str(tags / f"tag36h11_{tag_id:03d}.png"), image[..., ::-1],
                    [cv2.IMWRITE_PNG_COMPRESSION, 9])
    print(f"wrote ur10e_2f85.urdf, block.obj and {N_TAGS} tag textures under {HERE}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
