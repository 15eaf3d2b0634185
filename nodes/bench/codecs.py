"""Which codec for ``/camera/image_raw/compressed``: size, encode and decode time, and what
the detector measures on the decoded frame, for PNG and JPEG on the sim's own frames.

``python -m nodes.bench.codecs --seeds 16 --json docs/bench/image_codecs.json``: the
frames of ``densepack-bench perception`` (the arm parked), each encoded, decoded and given to
the detector as a bag replay would give it; ``raw`` is the frame itself.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys
import time
from collections.abc import Sequence

import numpy as np

from msgs_py.ros import image as image_codecs
from nodes.bench.perception import evaluate
from nodes.bench.sim_frames import sim_frames
from nodes.detector.config import DetectorConfig

#: (name, codec, PNG level or JPEG quality); ``raw`` is the uncompressed frame.
VARIANTS = (("raw", None, 0), ("png 1", "png", 1), ("png 9", "png", 9),
            ("jpeg 95", "jpeg", 95), ("jpeg 90", "jpeg", 90), ("jpeg 75", "jpeg", 75))


def encode(pixels: np.ndarray, codec: str, level: int):
    if codec == "png":
        image_codecs.PNG_LEVEL = level
    else:
        image_codecs.JPEG_QUALITY = level
    return image_codecs.array_to_compressed_image(pixels, 0, codec)


def main(args: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m nodes.bench.codecs",
                                     description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=16)
    parser.add_argument("--json", default=None, help="write the rows here")
    opts = parser.parse_args(args)
    frames, true_pose, _ = sim_frames(range(opts.seeds), 0.2, None)
    frames = [f for f in frames if f.situation == "parked"]
    rows = []
    for name, codec, level in VARIANTS:
        sizes, enc, dec, seen = [], [], [], []
        for frame in frames:
            if codec is None:
                sizes.append(frame.image.nbytes)
                seen.append(frame)
                continue
            t0 = time.perf_counter()
            msg = encode(frame.image, codec, level)
            t1 = time.perf_counter()
            pixels = image_codecs.compressed_image_to_array(msg)
            dec.append(time.perf_counter() - t1)
            enc.append(t1 - t0)
            sizes.append(len(msg.data))
            seen.append(dataclasses.replace(frame, image=pixels))
        det = evaluate(seen, DetectorConfig(), true_pose, "parked")
        row = {"variant": name, "frames": len(frames), "tags": det["tags"],
               "size_kB": float(np.mean(sizes)) / 1e3,
               "encode_ms": 1e3 * float(np.median(enc)) if enc else 0.0,
               "decode_ms": 1e3 * float(np.median(dec)) if dec else 0.0,
               **{k: det[k] for k in ("detection_rate", "pos_err_median_m", "pos_err_max_m",
                                      "yaw_err_median_deg", "yaw_err_max_deg")}}
        rows.append(row)
        print(f"{name:8s} {row['size_kB']:7.0f} kB  encode {row['encode_ms']:5.1f} ms  decode "
              f"{row['decode_ms']:5.1f} ms  detected {row['detection_rate']:.3f}  pos "
              f"{row['pos_err_median_m'] * 1e3:.3f}/{row['pos_err_max_m'] * 1e3:.3f} mm  yaw "
              f"{row['yaw_err_median_deg']:.3f}/{row['yaw_err_max_deg']:.3f} deg", flush=True)
    if opts.json:
        with open(opts.json, "w") as out:
            json.dump({"command": "python -m nodes.bench.codecs " + " ".join(args or
                                                                                   sys.argv[1:]),
                       "rows": rows}, out, indent=1)
            out.write("\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
