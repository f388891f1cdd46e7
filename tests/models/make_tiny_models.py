#!/usr/bin/env python3
"""Writes the tiny ONNX models psdr's tests run through ONNX Runtime (tests/tests/onnx_estimators.rs).

Each follows psdr's input contract (one float32 NCHW input [1, 3, H, W] holding the photo's sRGB values
normalised with ImageNet's mean and std; the CLIP stand-in with CLIP's) and undoes the normalisation first, so a test can tell whether psdr
normalised, resized and laid out the input as the contract says, and whether it reads the output right.

    pip install onnx numpy onnxruntime==1.31.1
    python3 tests/models/make_tiny_models.py
"""

import os

import numpy as np
import onnx
from onnx import TensorProto, helper, numpy_helper

HERE = os.path.dirname(os.path.abspath(__file__))
MEAN = np.array([0.485, 0.456, 0.406], dtype=np.float32)
STD = np.array([0.229, 0.224, 0.225], dtype=np.float32)


def unnormalise(nodes, inits, x):
    """x * std + mean per channel (back to sRGB 0..1)."""
    inits.append(numpy_helper.from_array(STD.reshape(1, 3, 1, 1), "std"))
    inits.append(numpy_helper.from_array(MEAN.reshape(1, 3, 1, 1), "mean"))
    nodes.append(helper.make_node("Mul", [x, "std"], ["scaled"]))
    nodes.append(helper.make_node("Add", ["scaled", "mean"], ["rgb"]))
    return "rgb"


def take_red(inits):
    """Slice bounds for channel 0 of axis 1: starts [0], ends [1], axes [1]."""
    inits.append(numpy_helper.from_array(np.array([0], dtype=np.int64), "zero"))
    inits.append(numpy_helper.from_array(np.array([1], dtype=np.int64), "one"))


def save(name, nodes, inits, inp, out):
    graph = helper.make_graph(nodes, name, [inp], [out], inits)
    model = helper.make_model(graph, opset_imports=[helper.make_opsetid("", 17)], producer_name="psdr-tests")
    model.ir_version = 8
    onnx.checker.check_model(model)
    path = os.path.join(HERE, name + ".onnx")
    onnx.save(model, path)
    return path


def tiny_depth():
    """Static [1,3,32,48] in; [1,1,16,24] out = the red channel, 2x2 average-pooled: checks resizing to a
    static, non-square input and the output's orientation and upsampling."""
    nodes, inits = [], []
    rgb = unnormalise(nodes, inits, "image")
    take_red(inits)
    nodes.append(helper.make_node("Slice", [rgb, "zero", "one", "one"], ["red"]))
    nodes.append(helper.make_node("AveragePool", ["red"], ["depth"], kernel_shape=[2, 2], strides=[2, 2]))
    inp = helper.make_tensor_value_info("image", TensorProto.FLOAT, [1, 3, 32, 48])
    out = helper.make_tensor_value_info("depth", TensorProto.FLOAT, [1, 1, 16, 24])
    return save("tiny_depth", nodes, inits, inp, out)


def tiny_segmentation():
    """Dynamic [1,3,height,width] in; [1,150,height/2,width/2] logits out: 2x2 average pooling of the sRGB
    colour, then logit[3] (floor) = 10 red, logit[0] (wall) = 10 green, logit[5] (ceiling) = 10 blue, every
    other logit 1. Pure red is floor, green wall, blue ceiling; black is class 1 (building: the first of the
    equal logits), which psdr keeps as an object. Checks dynamic sizes, argmax and the ADE20K mapping."""
    nodes, inits = [], []
    rgb = unnormalise(nodes, inits, "image")
    nodes.append(helper.make_node("AveragePool", [rgb], ["pooled"], kernel_shape=[2, 2], strides=[2, 2]))
    w = np.zeros((150, 3, 1, 1), dtype=np.float32)
    b = np.ones(150, dtype=np.float32)
    for cls, ch in [(3, 0), (0, 1), (5, 2)]:
        w[cls, ch, 0, 0] = 10.0
        b[cls] = 0.0
    inits.append(numpy_helper.from_array(w, "conv_w"))
    inits.append(numpy_helper.from_array(b, "conv_b"))
    nodes.append(helper.make_node("Conv", ["pooled", "conv_w", "conv_b"], ["logits"]))
    inp = helper.make_tensor_value_info("image", TensorProto.FLOAT, [1, 3, "height", "width"])
    out = helper.make_tensor_value_info("logits", TensorProto.FLOAT, [1, 150, None, None])
    return save("tiny_segmentation", nodes, inits, inp, out)


def tiny_fov():
    """Static [1,3,16,16] in; [1,1] out = 40 + 40 * mean(red): checks the normalisation (a wrong mean or std
    moves the answer)."""
    nodes, inits = [], []
    rgb = unnormalise(nodes, inits, "image")
    take_red(inits)
    nodes.append(helper.make_node("Slice", [rgb, "zero", "one", "one"], ["red"]))
    nodes.append(helper.make_node("ReduceMean", ["red"], ["mean_red"], keepdims=0))
    inits.append(numpy_helper.from_array(np.array(40.0, dtype=np.float32), "forty"))
    inits.append(numpy_helper.from_array(np.array([1, 1], dtype=np.int64), "shape11"))
    nodes.append(helper.make_node("Mul", ["mean_red", "forty"], ["scaled_red"]))
    nodes.append(helper.make_node("Add", ["scaled_red", "forty"], ["fov_scalar"]))
    nodes.append(helper.make_node("Reshape", ["fov_scalar", "shape11"], ["fov"]))
    inp = helper.make_tensor_value_info("image", TensorProto.FLOAT, [1, 3, 16, 16])
    out = helper.make_tensor_value_info("fov", TensorProto.FLOAT, [1, 1])
    return save("tiny_fov", nodes, inits, inp, out)


CLIP_MEAN = np.array([0.48145466, 0.4578275, 0.40821073], dtype=np.float32)
CLIP_STD = np.array([0.26862954, 0.26130258, 0.27577711], dtype=np.float32)


def tiny_clip_image():
    """CLIP's image-tower signature: static [1,3,224,224] normalised with CLIP's mean and std in; [1,512] out =
    the sRGB image 28x28 average-pooled to 3x8x8 (flattened, channel-major), then 320 zeros. Checks the CLIP
    normalisation (the ImageNet one, or none, moves every value) and resizing to 224x224."""
    nodes, inits = [], []
    inits.append(numpy_helper.from_array(CLIP_STD.reshape(1, 3, 1, 1), "std"))
    inits.append(numpy_helper.from_array(CLIP_MEAN.reshape(1, 3, 1, 1), "mean"))
    nodes.append(helper.make_node("Mul", ["pixel_values", "std"], ["scaled"]))
    nodes.append(helper.make_node("Add", ["scaled", "mean"], ["rgb"]))
    nodes.append(helper.make_node("AveragePool", ["rgb"], ["pooled"], kernel_shape=[28, 28], strides=[28, 28]))
    nodes.append(helper.make_node("Flatten", ["pooled"], ["flat"], axis=1))
    inits.append(numpy_helper.from_array(np.array([0, 0, 0, 320], dtype=np.int64), "pads"))
    nodes.append(helper.make_node("Pad", ["flat", "pads"], ["image_embeds"]))
    inp = helper.make_tensor_value_info("pixel_values", TensorProto.FLOAT, [1, 3, 224, 224])
    out = helper.make_tensor_value_info("image_embeds", TensorProto.FLOAT, [1, 512])
    return save("tiny_clip_image", nodes, inits, inp, out)


def normalise(rgb):
    return ((rgb - MEAN.reshape(1, 3, 1, 1)) / STD.reshape(1, 3, 1, 1)).astype(np.float32)


def pool2(a):
    """2x2 average pooling, stride 2, of an NCHW array with even H and W."""
    n, c, h, w = a.shape
    return a.reshape(n, c, h // 2, 2, w // 2, 2).mean(axis=(3, 5))


def seg_logits(rgb):
    """numpy's answer for tiny_segmentation: every logit 1, except floor (3), wall (0), ceiling (5)."""
    p = pool2(rgb)
    want = np.ones((1, 150) + p.shape[2:], dtype=np.float32)
    want[:, 3], want[:, 0], want[:, 5] = 10 * p[:, 0], 10 * p[:, 1], 10 * p[:, 2]
    return want


def check(label, got, want, tol=1e-5):
    assert got.shape == want.shape, (label, got.shape, want.shape)
    err = float(np.abs(got - want).max())
    assert err <= tol, (label, err)
    print(f"ok {label}: shape {list(got.shape)}, max |onnxruntime - numpy| = {err:.2e}")


def self_check(paths):
    """Runs each model with ONNX Runtime against numpy's answer (to 1e-5)."""
    import onnxruntime as ort

    depth, seg, fov, clip = (ort.InferenceSession(p, providers=["CPUExecutionProvider"]) for p in paths)

    # depth: a horizontal red ramp, 0 at the left to 1 at the right
    rgb = np.zeros((1, 3, 32, 48), dtype=np.float32)
    rgb[0, 0] = np.linspace(0, 1, 48, dtype=np.float32)[None, :]
    got = depth.run(None, {"image": normalise(rgb)})[0]
    check("tiny_depth red ramp", got, pool2(rgb[:, :1]))
    assert np.all(np.diff(got[0, 0], axis=1) > 0), "depth should grow left to right"

    # segmentation: red | green | blue | black stripes; then a dynamic size psdr would feed (multiples of 14)
    rgb = np.zeros((1, 3, 10, 12), dtype=np.float32)
    rgb[0, 0, :, 0:4] = 1
    rgb[0, 1, :, 4:8] = 1
    rgb[0, 2, :, 8:10] = 1
    got = seg.run(None, {"image": normalise(rgb)})[0]
    check("tiny_segmentation stripes 10x12", got, seg_logits(rgb))
    classes = got[0].argmax(axis=0)[0].tolist()
    assert classes == [3, 3, 0, 0, 5, 1], classes
    print(f"ok tiny_segmentation argmax per column: {classes} (red floor, green wall, blue ceiling, black 1)")
    rng = np.random.default_rng(0)
    rgb = rng.random((1, 3, 28, 42), dtype=np.float32)
    got = seg.run(None, {"image": normalise(rgb)})[0]
    check("tiny_segmentation random 28x42", got, seg_logits(rgb))

    # fov: uniform red 0.5 (green, blue 0) -> 40 + 40 * 0.5 = 60 degrees; then a random image
    rgb = np.zeros((1, 3, 16, 16), dtype=np.float32)
    rgb[0, 0] = 0.5
    got = fov.run(None, {"image": normalise(rgb)})[0]
    check("tiny_fov uniform red 0.5", got, np.array([[60.0]], dtype=np.float32))
    rgb = rng.random((1, 3, 16, 16), dtype=np.float32)
    got = fov.run(None, {"image": normalise(rgb)})[0]
    check("tiny_fov random", got, np.array([[40 + 40 * rgb[0, 0].mean()]], dtype=np.float32))

    # clip image: a random image, CLIP-normalised
    rgb = rng.random((1, 3, 224, 224), dtype=np.float32)
    clip_in = ((rgb - CLIP_MEAN.reshape(1, 3, 1, 1)) / CLIP_STD.reshape(1, 3, 1, 1)).astype(np.float32)
    got = clip.run(None, {"pixel_values": clip_in})[0]
    pooled = rgb.reshape(1, 3, 8, 28, 8, 28).mean(axis=(3, 5)).reshape(1, 192)
    check("tiny_clip_image random", got, np.concatenate([pooled, np.zeros((1, 320), np.float32)], axis=1))


if __name__ == "__main__":
    paths = [tiny_depth(), tiny_segmentation(), tiny_fov(), tiny_clip_image()]
    self_check(paths)
    for p in paths:
        print(f"{os.path.basename(p)}: {os.path.getsize(p)} bytes")
