#!/usr/bin/env python3
"""Reads frames from a V4L2 device with OpenCV (cv2.VideoCapture, V4L2 backend) as vision code
does, and prints the centre of the orange pixels (the ball) of the last frame: `ball X Y COUNT`,
plus the size read: `size W H`. Usage: opencv_ball.py DEVICE_INDEX WIDTH HEIGHT [FRAMES]."""
import sys

import cv2
import numpy as np


def main():
    index, width, height = int(sys.argv[1]), int(sys.argv[2]), int(sys.argv[3])
    frames = int(sys.argv[4]) if len(sys.argv) > 4 else 5
    cap = cv2.VideoCapture(index, cv2.CAP_V4L2)
    if not cap.isOpened():
        print("cannot open /dev/video%d" % index)
        return 1
    cap.set(cv2.CAP_PROP_FRAME_WIDTH, width)
    cap.set(cv2.CAP_PROP_FRAME_HEIGHT, height)
    image = None
    for _ in range(frames):
        ok, image = cap.read()
        if not ok:
            print("read failed")
            return 1
    print("size %d %d" % (image.shape[1], image.shape[0]))
    hsv = cv2.cvtColor(image, cv2.COLOR_BGR2HSV)
    # Orange: hue 8..20 of OpenCV's 0..180 (the ball, RGB 255 120 0, is 14; the yellow goal, 240 210 20, is 26).
    mask = cv2.inRange(hsv, np.array([8, 150, 120]), np.array([20, 255, 255]))
    ys, xs = np.nonzero(mask)
    if len(xs) == 0:
        print("ball none 0")
        return 0
    print("ball %.2f %.2f %d" % (xs.mean(), ys.mean(), len(xs)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
