// A vision loop written from the V4L2 specification (linux/videodev2.h; "Streaming I/O (Memory
// Mapping)", VIDIOC_REQBUFS/QUERYBUF/QBUF/DQBUF/STREAMON) and the man pages, never with Doppel's
// code: the program a team runs against a webcam, here under doppel-run --lockstep.
//
//   lockstep_vision MODE DEVICE N
//
// MODE poll: open DEVICE, S_FMT YUYV 320x240, REQBUFS 4 MMAP, QUERYBUF + mmap, QBUF all,
//   STREAMON, then N times: poll(POLLIN, 1 s) + DQBUF, process, QBUF. Prints one line per frame
//   "frame I seq=S stamp_us=T got_us=G top=F bottom=F" (T the buffer's timestamp, G CLOCK_MONOTONIC
//   when DQBUF returned, both in microseconds; top and bottom the fraction of YUYV pairs whose
//   chroma is green, Cb < 128 and Cr < 128, in the upper and the lower half of the image) and at
//   the end "frames=N hash=HEX", FNV-1a 64 over
//   every frame's sequence, timestamp and pixels.
// MODE dqbuf: the same with a blocking DQBUF and no poll.
// MODE select: the same with select() (the DARwIn-OP framework's LinuxCamera waits so).
// MODE read: no buffers: N blocking read() calls of one whole frame each ("Read/Write" I/O).
//   Prints "read I bytes=B got_us=G top=F bottom=F" per frame and the hash of the pixels.
// MODE idle: STREAMON and never dequeue; sleep N/10 s (nanosleep), close without STREAMOFF.
//   Prints "idle_end_us=T".
// MODE restart: N frames with poll, STREAMOFF, a DQBUF (must fail with EINVAL), QBUF every
//   buffer again, STREAMON, N frames more. Prints the frame lines and "after_streamoff=ERRNO".
// MODE busy: a second descriptor of the same device asks for buffers while the first holds them.
//   Prints "second_reqbufs=ERRNO".
#include <errno.h>
#include <fcntl.h>
#include <linux/videodev2.h>
#include <poll.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/ioctl.h>
#include <sys/mman.h>
#include <sys/select.h>
#include <time.h>
#include <unistd.h>

#define WIDTH 320
#define HEIGHT 240
#define BUFFERS 4

static uint64_t hash = 14695981039346656037ULL;  // FNV-1a 64 offset basis

static void hash_bytes(const void* data, size_t n) {
  const uint8_t* p = data;
  for (size_t i = 0; i < n; ++i) {
    hash ^= p[i];
    hash *= 1099511628211ULL;  // FNV-1a 64 prime
  }
}

static int xioctl(int fd, unsigned long request, void* arg) {
  int r;
  do {
    r = ioctl(fd, request, arg);
  } while (r == -1 && errno == EINTR);
  return r;
}

static void die(const char* what) {
  fprintf(stderr, "%s: %s\n", what, strerror(errno));
  exit(1);
}

static int64_t monotonic_us(void) {
  struct timespec ts;
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return (int64_t)ts.tv_sec * 1000000 + ts.tv_nsec / 1000;
}

struct Buffer {
  void* start;
  size_t length;
};
static struct Buffer buffers[BUFFERS];
static int frame_index = 0;

// A capture buffer of MMAP memory, `index`, as the ioctls that take one want it.
static struct v4l2_buffer mmap_buffer(unsigned index) {
  struct v4l2_buffer b;
  memset(&b, 0, sizeof b);
  b.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  b.memory = V4L2_MEMORY_MMAP;
  b.index = index;
  return b;
}

static int open_device(const char* device) {
  const int fd = open(device, O_RDWR);
  if (fd < 0) die("open");
  struct v4l2_capability cap;
  memset(&cap, 0, sizeof cap);
  if (xioctl(fd, VIDIOC_QUERYCAP, &cap) != 0) die("VIDIOC_QUERYCAP");
  if ((cap.device_caps & V4L2_CAP_VIDEO_CAPTURE) == 0 || (cap.device_caps & V4L2_CAP_STREAMING) == 0) {
    fprintf(stderr, "not a streaming capture device\n");
    exit(1);
  }
  struct v4l2_format format;
  memset(&format, 0, sizeof format);
  format.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  format.fmt.pix.width = WIDTH;
  format.fmt.pix.height = HEIGHT;
  format.fmt.pix.pixelformat = V4L2_PIX_FMT_YUYV;
  format.fmt.pix.field = V4L2_FIELD_NONE;
  if (xioctl(fd, VIDIOC_S_FMT, &format) != 0) die("VIDIOC_S_FMT");
  if (format.fmt.pix.width != WIDTH || format.fmt.pix.height != HEIGHT || format.fmt.pix.pixelformat != V4L2_PIX_FMT_YUYV) {
    fprintf(stderr, "got %ux%u\n", format.fmt.pix.width, format.fmt.pix.height);
    exit(1);
  }
  return fd;
}

static void map_buffers(int fd) {
  struct v4l2_requestbuffers request;
  memset(&request, 0, sizeof request);
  request.count = BUFFERS;
  request.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  request.memory = V4L2_MEMORY_MMAP;
  if (xioctl(fd, VIDIOC_REQBUFS, &request) != 0) die("VIDIOC_REQBUFS");
  if (request.count != BUFFERS) {
    fprintf(stderr, "got %u buffers\n", request.count);
    exit(1);
  }
  for (unsigned i = 0; i < BUFFERS; ++i) {
    struct v4l2_buffer b = mmap_buffer(i);
    if (xioctl(fd, VIDIOC_QUERYBUF, &b) != 0) die("VIDIOC_QUERYBUF");
    buffers[i].length = b.length;
    buffers[i].start = mmap(NULL, b.length, PROT_READ | PROT_WRITE, MAP_SHARED, fd, b.m.offset);
    if (buffers[i].start == MAP_FAILED) die("mmap");
  }
}

static void queue_all(int fd) {
  for (unsigned i = 0; i < BUFFERS; ++i) {
    struct v4l2_buffer b = mmap_buffer(i);
    if (xioctl(fd, VIDIOC_QBUF, &b) != 0) die("VIDIOC_QBUF");
  }
}

static void stream(int fd, int on) {
  int type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  if (xioctl(fd, on ? VIDIOC_STREAMON : VIDIOC_STREAMOFF, &type) != 0) die(on ? "VIDIOC_STREAMON" : "VIDIOC_STREAMOFF");
}

// Fraction of YUYV pairs (Y0 Cb Y1 Cr) in rows [first, last) whose chroma is green: BT.601 Cb and Cr
// both below neutral means B < Y and R < Y, i.e. green dominates.
static double green_fraction(const uint8_t* p, int first, int last) {
  long green = 0, pairs = 0;
  for (int row = first; row < last; ++row) {
    for (int x = 0; x < WIDTH / 2; ++x) {
      const uint8_t* pair = p + (size_t)row * WIDTH * 2 + (size_t)x * 4;
      green += pair[1] < 128 && pair[3] < 128 ? 1 : 0;
      ++pairs;
    }
  }
  return (double)green / (double)pairs;
}

// Waits for a filled buffer as MODE says, dequeues it, processes it and queues it again.
static void next_frame(int fd, const char* mode) {
  if (strcmp(mode, "poll") == 0 || strcmp(mode, "restart") == 0) {
    struct pollfd p = {fd, POLLIN, 0};
    const int r = poll(&p, 1, 1000);
    if (r != 1) {
      fprintf(stderr, "poll: %d (%s)\n", r, r < 0 ? strerror(errno) : "timeout");
      exit(1);
    }
  } else if (strcmp(mode, "select") == 0) {
    fd_set set;
    FD_ZERO(&set);
    FD_SET(fd, &set);
    struct timeval timeout = {1, 0};
    const int r = select(fd + 1, &set, NULL, NULL, &timeout);
    if (r != 1) {
      fprintf(stderr, "select: %d (%s)\n", r, r < 0 ? strerror(errno) : "timeout");
      exit(1);
    }
  }
  struct v4l2_buffer b = mmap_buffer(0);
  if (xioctl(fd, VIDIOC_DQBUF, &b) != 0) die("VIDIOC_DQBUF");
  const int64_t got_us = monotonic_us();
  const int64_t stamp_us = (int64_t)b.timestamp.tv_sec * 1000000 + b.timestamp.tv_usec;
  if (b.bytesused != WIDTH * HEIGHT * 2 || (b.flags & V4L2_BUF_FLAG_ERROR) != 0) {
    fprintf(stderr, "frame %d: %u bytes, flags %x\n", frame_index, b.bytesused, b.flags);
    exit(1);
  }
  const uint8_t* pixels = buffers[b.index].start;
  hash_bytes(&b.sequence, sizeof b.sequence);
  hash_bytes(&stamp_us, sizeof stamp_us);
  hash_bytes(pixels, b.bytesused);
  printf("frame %d seq=%u stamp_us=%lld got_us=%lld top=%.4f bottom=%.4f\n", frame_index++, b.sequence,
         (long long)stamp_us, (long long)got_us, green_fraction(pixels, 0, HEIGHT / 2),
         green_fraction(pixels, HEIGHT / 2, HEIGHT));
  if (xioctl(fd, VIDIOC_QBUF, &b) != 0) die("VIDIOC_QBUF");
}

int main(int argc, char** argv) {
  if (argc != 4) {
    fprintf(stderr, "usage: lockstep_vision poll|dqbuf|select|read|idle|restart|busy DEVICE N\n");
    return 2;
  }
  const char* mode = argv[1];
  const int n = atoi(argv[3]);
  const int fd = open_device(argv[2]);
  if (strcmp(mode, "busy") == 0) {
    map_buffers(fd);
    const int other = open(argv[2], O_RDWR);
    if (other < 0) die("open (second)");
    struct v4l2_requestbuffers request;
    memset(&request, 0, sizeof request);
    request.count = 2;
    request.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    request.memory = V4L2_MEMORY_MMAP;
    const int r = xioctl(other, VIDIOC_REQBUFS, &request);
    printf("second_reqbufs=%s\n", r == 0 ? "0" : strerror(errno));
    close(other);
    close(fd);
    return 0;
  }
  if (strcmp(mode, "read") == 0) {
    static uint8_t frame[WIDTH * HEIGHT * 2];
    for (int i = 0; i < n; ++i) {
      const ssize_t r = read(fd, frame, sizeof frame);
      if (r < 0) die("read");
      const int64_t got_us = monotonic_us();
      hash_bytes(frame, (size_t)r);
      printf("read %d bytes=%zd got_us=%lld top=%.4f bottom=%.4f\n", i, r, (long long)got_us,
             green_fraction(frame, 0, HEIGHT / 2), green_fraction(frame, HEIGHT / 2, HEIGHT));
    }
    close(fd);
    printf("frames=%d hash=%016llx\n", n, (unsigned long long)hash);
    return 0;
  }
  map_buffers(fd);
  queue_all(fd);
  stream(fd, 1);
  if (strcmp(mode, "idle") == 0) {
    const struct timespec wait = {n / 10, (long)(n % 10) * 100000000L};
    nanosleep(&wait, NULL);
    close(fd);
    printf("idle_end_us=%lld\n", (long long)monotonic_us());
    return 0;
  }
  for (int i = 0; i < n; ++i) next_frame(fd, mode);
  if (strcmp(mode, "restart") == 0) {
    stream(fd, 0);
    struct v4l2_buffer b = mmap_buffer(0);
    const int r = xioctl(fd, VIDIOC_DQBUF, &b);
    printf("after_streamoff=%s\n", r == 0 ? "0" : strerror(errno));
    queue_all(fd);
    stream(fd, 1);
    for (int i = 0; i < n; ++i) next_frame(fd, "poll");
  }
  stream(fd, 0);
  for (unsigned i = 0; i < BUFFERS; ++i) munmap(buffers[i].start, buffers[i].length);
  close(fd);
  printf("frames=%d hash=%016llx\n", frame_index, (unsigned long long)hash);
  return 0;
}
