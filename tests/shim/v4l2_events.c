/* Control events on a V4L2 capture device, written from the V4L2 specification ("Event Interface",
 * VIDIOC_SUBSCRIBE_EVENT, VIDIOC_DQEVENT, "Control Events"): what a program that watches its
 * camera's controls relies on. Usage: v4l2_events DEVICE. Prints "ok NAME" or "FAIL NAME: why" per
 * check; exits 0 when every check passed. */
#include <errno.h>
#include <fcntl.h>
#include <linux/videodev2.h>
#include <poll.h>
#include <pthread.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>
#include <sys/ioctl.h>
#include <sys/select.h>
#include <time.h>
#include <unistd.h>

static int failures = 0;

static void check(int ok, const char* name, const char* why) {
  if (ok) {
    printf("ok %s\n", name);
  } else {
    printf("FAIL %s: %s (errno %s)\n", name, why, strerror(errno));
    ++failures;
  }
}

static int subscribe(int fd, unsigned long request, uint32_t type, uint32_t id, uint32_t flags) {
  struct v4l2_event_subscription sub;
  memset(&sub, 0, sizeof(sub));
  sub.type = type;
  sub.id = id;
  sub.flags = flags;
  return ioctl(fd, request, &sub);
}

static int set_control(int fd, uint32_t id, int32_t value) {
  struct v4l2_control c = {id, value};
  return ioctl(fd, VIDIOC_S_CTRL, &c);
}

/* What poll() reports for fd asked for POLLIN and POLLPRI, without waiting. */
static short polled(int fd) {
  struct pollfd p = {fd, POLLIN | POLLPRI, 0};
  return poll(&p, 1, 0) == 1 ? p.revents : 0;
}

static int dequeue(int fd, struct v4l2_event* ev) {
  memset(ev, 0xff, sizeof(*ev));
  return ioctl(fd, VIDIOC_DQEVENT, ev);
}

static long long us_of(struct timespec t) { return (long long)t.tv_sec * 1000000 + t.tv_nsec / 1000; }

static long long now_us(void) {
  struct timespec t;
  clock_gettime(CLOCK_MONOTONIC, &t);
  return us_of(t);
}

struct Later {
  int fd;
  uint32_t id;
  int32_t value;
  long long set_us;  /* CLOCK_MONOTONIC just before the change */
};

static void* set_later(void* p) {
  struct Later* later = p;
  const struct timespec pause = {0, 200 * 1000 * 1000};
  nanosleep(&pause, NULL);
  later->set_us = now_us();
  set_control(later->fd, later->id, later->value);
  return NULL;
}

int main(int argc, char** argv) {
  if (argc != 2) {
    fprintf(stderr, "usage: v4l2_events DEVICE\n");
    return 2;
  }
  const int watcher = open(argv[1], O_RDWR | O_NONBLOCK);
  const int setter = open(argv[1], O_RDWR | O_NONBLOCK);
  const int blocking = open(argv[1], O_RDWR);
  if (watcher < 0 || setter < 0 || blocking < 0) {
    perror(argv[1]);
    return 2;
  }
  struct v4l2_queryctrl q;
  memset(&q, 0, sizeof(q));
  q.id = V4L2_CID_BRIGHTNESS;
  struct v4l2_control current = {V4L2_CID_BRIGHTNESS, 0};
  if (ioctl(watcher, VIDIOC_QUERYCTRL, &q) != 0 || ioctl(watcher, VIDIOC_G_CTRL, &current) != 0) {
    perror("brightness");
    return 2;
  }
  struct v4l2_event ev;

  /* Nothing subscribed: nothing to dequeue, no POLLPRI. */
  check(dequeue(watcher, &ev) == -1 && errno == ENOENT, "nothing-subscribed-is-ENOENT", "DQEVENT");
  check((polled(watcher) & POLLPRI) == 0, "nothing-subscribed-no-POLLPRI", "poll");

  /* The initial event: the control's whole state, at once. */
  check(subscribe(watcher, VIDIOC_SUBSCRIBE_EVENT, V4L2_EVENT_CTRL, V4L2_CID_BRIGHTNESS, V4L2_EVENT_SUB_FL_SEND_INITIAL) == 0,
        "subscribe-brightness", "SUBSCRIBE_EVENT");
  check(polled(watcher) == POLLPRI, "initial-event-is-POLLPRI-only", "poll (not streaming: no POLLIN)");
  struct timespec before;
  clock_gettime(CLOCK_MONOTONIC, &before);
  check(dequeue(watcher, &ev) == 0, "initial-event-dequeued", "DQEVENT");
  check(ev.type == V4L2_EVENT_CTRL && ev.id == V4L2_CID_BRIGHTNESS, "initial-event-names-the-control", "type/id");
  check(ev.u.ctrl.changes == (V4L2_EVENT_CTRL_CH_VALUE | V4L2_EVENT_CTRL_CH_FLAGS), "initial-event-changes-value-and-flags", "changes");
  check(ev.u.ctrl.type == q.type && ev.u.ctrl.value == current.value && ev.u.ctrl.flags == q.flags &&
            ev.u.ctrl.minimum == q.minimum && ev.u.ctrl.maximum == q.maximum && ev.u.ctrl.step == q.step &&
            ev.u.ctrl.default_value == q.default_value,
        "initial-event-is-QUERYCTRL-and-G_CTRL", "type/value/flags/range");
  check(ev.pending == 0 && ev.sequence == 0, "initial-event-first-and-last", "pending/sequence");
  check(ev.timestamp.tv_sec > 0 && (ev.timestamp.tv_sec < before.tv_sec || (ev.timestamp.tv_sec == before.tv_sec &&
                                                                             ev.timestamp.tv_nsec <= before.tv_nsec)),
        "initial-event-on-CLOCK_MONOTONIC", "timestamp (queued before the dequeue)");
  check(dequeue(watcher, &ev) == -1 && errno == ENOENT && (polled(watcher) & POLLPRI) == 0, "dequeued-means-gone", "DQEVENT/poll");
  check(subscribe(watcher, VIDIOC_SUBSCRIBE_EVENT, V4L2_EVENT_CTRL, V4L2_CID_BRIGHTNESS, V4L2_EVENT_SUB_FL_SEND_INITIAL) == 0 &&
            dequeue(watcher, &ev) == -1 && errno == ENOENT,
        "subscribing-again-sends-nothing", "SUBSCRIBE_EVENT twice");

  /* Another descriptor's change reaches the watcher; two before a dequeue merge into one. */
  const int32_t first = q.minimum + q.step, second = q.minimum + 2 * q.step;
  set_control(setter, V4L2_CID_BRIGHTNESS, first);
  check(dequeue(watcher, &ev) == 0 && ev.u.ctrl.changes == V4L2_EVENT_CTRL_CH_VALUE && ev.u.ctrl.value == first && ev.sequence == 1,
        "another-descriptors-change-is-an-event", "DQEVENT after S_CTRL");
  set_control(setter, V4L2_CID_BRIGHTNESS, first);
  check(dequeue(watcher, &ev) == -1 && errno == ENOENT, "setting-the-same-value-is-no-change", "DQEVENT");
  set_control(setter, V4L2_CID_BRIGHTNESS, second);
  set_control(setter, V4L2_CID_BRIGHTNESS, first);
  check(dequeue(watcher, &ev) == 0 && ev.u.ctrl.value == first && ev.sequence == 3 && ev.pending == 0 &&
            dequeue(watcher, &ev) == -1,
        "changes-before-a-dequeue-merge-into-the-newest", "DQEVENT x2");

  /* Its own changes only when asked for (V4L2_EVENT_SUB_FL_ALLOW_FEEDBACK). */
  set_control(watcher, V4L2_CID_BRIGHTNESS, second);
  check(dequeue(watcher, &ev) == -1 && errno == ENOENT, "own-change-no-event", "DQEVENT");
  check(subscribe(watcher, VIDIOC_SUBSCRIBE_EVENT, V4L2_EVENT_CTRL, V4L2_CID_CONTRAST, V4L2_EVENT_SUB_FL_ALLOW_FEEDBACK) == 0,
        "subscribe-contrast-with-feedback", "SUBSCRIBE_EVENT");
  struct v4l2_control contrast = {V4L2_CID_CONTRAST, 0};
  ioctl(watcher, VIDIOC_G_CTRL, &contrast);
  set_control(watcher, V4L2_CID_CONTRAST, contrast.value + 1);
  check(dequeue(watcher, &ev) == 0 && ev.id == V4L2_CID_CONTRAST && ev.u.ctrl.value == contrast.value + 1,
        "own-change-with-feedback-is-an-event", "DQEVENT");

  /* Automatic white balance on makes the temperature inactive: a flags event. Events come oldest first. */
  check(subscribe(watcher, VIDIOC_SUBSCRIBE_EVENT, V4L2_EVENT_CTRL, V4L2_CID_WHITE_BALANCE_TEMPERATURE, 0) == 0,
        "subscribe-temperature", "SUBSCRIBE_EVENT");
  set_control(setter, V4L2_CID_AUTO_WHITE_BALANCE, 0);
  while (dequeue(watcher, &ev) == 0) {
  }
  set_control(setter, V4L2_CID_BRIGHTNESS, first);
  set_control(setter, V4L2_CID_AUTO_WHITE_BALANCE, 1);
  check(dequeue(watcher, &ev) == 0 && ev.id == V4L2_CID_BRIGHTNESS && ev.pending == 1, "events-in-the-order-queued", "DQEVENT");
  check(dequeue(watcher, &ev) == 0 && ev.id == V4L2_CID_WHITE_BALANCE_TEMPERATURE && ev.u.ctrl.changes == V4L2_EVENT_CTRL_CH_FLAGS &&
            (ev.u.ctrl.flags & V4L2_CTRL_FLAG_INACTIVE) != 0 && ev.pending == 0,
        "auto-white-balance-makes-temperature-inactive", "DQEVENT");

  /* select's exception set and pselect see a waiting event; one without is not reported. */
  set_control(setter, V4L2_CID_BRIGHTNESS, second);
  fd_set ex;
  FD_ZERO(&ex);
  FD_SET(watcher, &ex);
  struct timeval tv = {0, 100};
  check(select(watcher + 1, NULL, NULL, &ex, &tv) == 1 && FD_ISSET(watcher, &ex), "select-exception-set", "select");
  FD_ZERO(&ex);
  FD_SET(watcher, &ex);
  FD_SET(setter, &ex);
  const struct timespec ts = {0, 100000};
  check(pselect(setter > watcher ? setter + 1 : watcher + 1, NULL, NULL, &ex, &ts, NULL) == 1 && FD_ISSET(watcher, &ex) &&
            !FD_ISSET(setter, &ex),
        "pselect-only-the-waiting-one", "pselect");

  /* Unsubscribing drops the control's waiting event; V4L2_EVENT_ALL ends every subscription. */
  check(subscribe(watcher, VIDIOC_UNSUBSCRIBE_EVENT, V4L2_EVENT_CTRL, V4L2_CID_BRIGHTNESS, 0) == 0 &&
            dequeue(watcher, &ev) == -1 && errno == ENOENT && (polled(watcher) & POLLPRI) == 0,
        "unsubscribe-drops-waiting-event", "UNSUBSCRIBE_EVENT");
  set_control(setter, V4L2_CID_BRIGHTNESS, first);
  check(dequeue(watcher, &ev) == -1 && errno == ENOENT, "unsubscribed-no-event", "DQEVENT");
  check(subscribe(watcher, VIDIOC_UNSUBSCRIBE_EVENT, V4L2_EVENT_ALL, 0, 0) == 0, "unsubscribe-all", "UNSUBSCRIBE_EVENT");
  set_control(setter, V4L2_CID_CONTRAST, contrast.value);
  set_control(setter, V4L2_CID_AUTO_WHITE_BALANCE, 0);
  check(dequeue(watcher, &ev) == -1 && errno == ENOENT, "unsubscribed-all-no-event", "DQEVENT");

  /* What the device does not have is EINVAL. */
  check(subscribe(watcher, VIDIOC_SUBSCRIBE_EVENT, V4L2_EVENT_CTRL, V4L2_CID_HUE, 0) == -1 && errno == EINVAL,
        "unknown-control-EINVAL", "SUBSCRIBE_EVENT");
  check(subscribe(watcher, VIDIOC_SUBSCRIBE_EVENT, V4L2_EVENT_EOS, 0, 0) == -1 && errno == EINVAL, "other-event-type-EINVAL",
        "SUBSCRIBE_EVENT");
  check(subscribe(watcher, VIDIOC_SUBSCRIBE_EVENT, V4L2_EVENT_ALL, 0, 0) == -1 && errno == EINVAL, "subscribe-all-EINVAL",
        "SUBSCRIBE_EVENT");

  /* A blocking descriptor's DQEVENT waits for the event (poll too, with no timeout). The times
   * (simulation time under doppel-run --lockstep) say when the change was made, when the event was
   * stamped and when the wait ended. */
  subscribe(blocking, VIDIOC_SUBSCRIBE_EVENT, V4L2_EVENT_CTRL, V4L2_CID_BRIGHTNESS, 0);
  struct Later later = {setter, V4L2_CID_BRIGHTNESS, second, 0};
  pthread_t thread;
  pthread_create(&thread, NULL, set_later, &later);
  check(dequeue(blocking, &ev) == 0 && ev.u.ctrl.value == second, "blocking-DQEVENT-waits", "DQEVENT");
  const long long woke_us = now_us();
  pthread_join(thread, NULL);
  printf("set_us=%lld event_us=%lld woke_us=%lld\n", later.set_us, us_of(ev.timestamp), woke_us);
  later.value = first;
  pthread_create(&thread, NULL, set_later, &later);
  struct pollfd p = {blocking, POLLPRI, 0};
  check(poll(&p, 1, -1) == 1 && p.revents == POLLPRI && dequeue(blocking, &ev) == 0 && ev.u.ctrl.value == first,
        "poll-waits-for-POLLPRI", "poll");
  pthread_join(thread, NULL);

  close(blocking);
  close(setter);
  close(watcher);
  printf("%d failed\n", failures);
  return failures == 0 ? 0 : 1;
}
