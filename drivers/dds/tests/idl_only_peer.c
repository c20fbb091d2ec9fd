/* An independent DDS peer for the interop tests (issue 5: "a subscriber built only from the
 * IDL"). Plain C on Cyclone's C API and the types idlc generates from idl/fillet_line.idl,
 * with the topic names and QoS written down from docs/dds.md, and nothing of the project's
 * own DDS code: it is what a camera vendor or an MES integrator would write from the docs.
 *
 *   idl_only_peer publish-estimates DOMAIN CAMERA FRAMES
 *     A camera node: waits for a reader, then FRAMES frames 5 ms apart, frame n (1..) with
 *     one fillet at x = n mm, y = -5 mm, 0.25 rad, confidence 0.9, left, bone side up.
 *   idl_only_peer read-ledger DOMAIN RECORDS TIMEOUT_MS
 *     An MES: prints "record ID OUTCOME HAND" per ledger record until RECORDS arrived.
 *
 * Exit 0 on success, 1 when the wait timed out, 2 on bad arguments or a DDS error. */
#include <dds/dds.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "fillet_line.h"

static long long monotonic_ns(void) {
  struct timespec now;
  clock_gettime(CLOCK_MONOTONIC, &now);
  return (long long)now.tv_sec * 1000000000LL + now.tv_nsec;
}

static int fail(const char* what, dds_return_t code) {
  fprintf(stderr, "idl_only_peer: %s: %s\n", what, dds_strretcode(code));
  return 2;
}

/* docs/dds.md, fl/camera/estimates: reliable, keep-last 1, volatile, deadline and automatic
 * liveliness of 3 periods of the slowest camera (40 ms), by source timestamp. */
static dds_qos_t* estimates_qos(void) {
  dds_qos_t* qos = dds_create_qos();
  dds_qset_reliability(qos, DDS_RELIABILITY_RELIABLE, DDS_MSECS(10));
  dds_qset_history(qos, DDS_HISTORY_KEEP_LAST, 1);
  dds_qset_durability(qos, DDS_DURABILITY_VOLATILE);
  dds_qset_deadline(qos, DDS_MSECS(120));
  dds_qset_liveliness(qos, DDS_LIVELINESS_AUTOMATIC, DDS_MSECS(120));
  dds_qset_destination_order(qos, DDS_DESTINATIONORDER_BY_SOURCE_TIMESTAMP);
  return qos;
}

/* docs/dds.md, fl/line/ledger: reliable, transient-local, keep-last LEDGER_HISTORY. */
static dds_qos_t* ledger_qos(void) {
  dds_qos_t* qos = dds_create_qos();
  dds_qset_reliability(qos, DDS_RELIABILITY_RELIABLE, DDS_MSECS(100));
  dds_qset_history(qos, DDS_HISTORY_KEEP_LAST, fl_LEDGER_HISTORY);
  dds_qset_durability(qos, DDS_DURABILITY_TRANSIENT_LOCAL);
  return qos;
}

static int publish_estimates(dds_entity_t participant, int camera, int frames) {
  const dds_entity_t topic =
      dds_create_topic(participant, &fl_CameraEstimates_desc, "fl/camera/estimates", NULL, NULL);
  if (topic < 0) return fail("create topic fl/camera/estimates", topic);
  dds_qos_t* qos = estimates_qos();
  const dds_entity_t writer = dds_create_writer(participant, topic, qos, NULL);
  dds_delete_qos(qos);
  if (writer < 0) return fail("create writer", writer);
  dds_publication_matched_status_t matched;
  const long long give_up_ns = monotonic_ns() + 10000000000LL;
  do {
    const dds_return_t rc = dds_get_publication_matched_status(writer, &matched);
    if (rc < 0) return fail("publication matched status", rc);
    if (matched.current_count > 0) break;
    dds_sleepfor(DDS_MSECS(5));
  } while (monotonic_ns() < give_up_ns);
  if (matched.current_count == 0) {
    fprintf(stderr, "idl_only_peer: no estimates reader matched within 10 s\n");
    return 1;
  }
  for (int n = 1; n <= frames; ++n) {
    fl_CameraEstimates sample;
    memset(&sample, 0, sizeof sample);
    sample.camera_id = (uint8_t)camera;
    sample.frame_time_ns = monotonic_ns();
    sample.frame_sequence = (uint32_t)n;
    sample.count = 1;
    sample.estimates[0].x_mm = (float)n;
    sample.estimates[0].y_mm = -5.0F;
    sample.estimates[0].angle_rad = 0.25F;
    sample.estimates[0].confidence = 0.9F;
    sample.estimates[0].hand = fl_HAND_LEFT;
    sample.estimates[0].side = fl_SIDE_BONE;
    sample.estimates[0].singulated = true;
    const dds_return_t rc = dds_write(writer, &sample);
    if (rc < 0) return fail("write estimates", rc);
    dds_sleepfor(DDS_MSECS(5));
  }
  /* Reliable repair of the last frame before the participant goes. */
  dds_sleepfor(DDS_MSECS(200));
  return 0;
}

static int read_ledger(dds_entity_t participant, int records, int timeout_ms) {
  const dds_entity_t topic =
      dds_create_topic(participant, &fl_FilletLedgerRecord_desc, "fl/line/ledger", NULL, NULL);
  if (topic < 0) return fail("create topic fl/line/ledger", topic);
  dds_qos_t* qos = ledger_qos();
  const dds_entity_t reader = dds_create_reader(participant, topic, qos, NULL);
  dds_delete_qos(qos);
  if (reader < 0) return fail("create reader", reader);
  printf("ready\n");
  fflush(stdout);
  int taken = 0;
  const long long give_up_ns = monotonic_ns() + (long long)timeout_ms * 1000000LL;
  while (taken < records && monotonic_ns() < give_up_ns) {
    void* samples[1] = {NULL};
    dds_sample_info_t info;
    const dds_return_t count = dds_take(reader, samples, &info, 1, 1);
    if (count < 0) return fail("take", count);
    if (count == 1 && info.valid_data) {
      const fl_FilletLedgerRecord* record = (const fl_FilletLedgerRecord*)samples[0];
      printf("record %u %u %d\n", (unsigned)record->id, (unsigned)record->outcome,
             (int)record->hand);
      fflush(stdout);
      ++taken;
    }
    if (count > 0) dds_return_loan(reader, samples, count);
    if (count == 0) dds_sleepfor(DDS_MSECS(2));
  }
  return taken == records ? 0 : 1;
}

int main(int argc, char** argv) {
  if (argc != 5) {
    fprintf(stderr,
            "usage: idl_only_peer publish-estimates DOMAIN CAMERA FRAMES\n"
            "       idl_only_peer read-ledger DOMAIN RECORDS TIMEOUT_MS\n");
    return 2;
  }
  const int domain = atoi(argv[2]);
  const int a = atoi(argv[3]);
  const int b = atoi(argv[4]);
  const dds_entity_t participant = dds_create_participant((dds_domainid_t)domain, NULL, NULL);
  if (participant < 0) return fail("create participant", participant);
  int status = 2;
  if (strcmp(argv[1], "publish-estimates") == 0) {
    status = publish_estimates(participant, a, b);
  } else if (strcmp(argv[1], "read-ledger") == 0) {
    status = read_ledger(participant, a, b);
  } else {
    fprintf(stderr, "idl_only_peer: unknown mode %s\n", argv[1]);
  }
  dds_delete(participant);
  return status;
}
