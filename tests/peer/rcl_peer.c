/*
 * grasp_orient_rcl_peer: a load generator and a collector for the node benchmark, written on rcl,
 * the C client library under rclpy and rclcpp, over rmw_fastrtps_cpp (Fast DDS): the same stack as a
 * ROS 2 Jazzy robot, without Python's cost per message, so that the peer is not what limits the
 * measurement on a small machine. Built by tests/peer/setup.sh; driven by benches/bench_node.py.
 *
 *   grasp_orient_rcl_peer pub TOPIC POOL RATE COUNT TAG DEPTH
 *       POOL: serialized GraspCandidate messages (CDR with encapsulation), each as a little-endian u32
 *       length and the bytes, every id "TAG-00000000". Prints "ready" once a subscription matches, reads
 *       "go T" (T: CLOCK_MONOTONIC seconds), then publishes COUNT messages, the k-th with id TAG-k
 *       (8 digits) at T + k / RATE (RATE 0: as fast as it can), waits for every subscription to
 *       acknowledge, and prints one JSON line. Exits after the next line (or EOF) on stdin.
 *   grasp_orient_rcl_peer sub TOPIC TYPE COUNT TAG IDLE DEPTH
 *       TYPE: candidate | recommendation. Prints "ready" once a publisher matches, reads "go T RATE",
 *       then takes serialized messages until COUNT distinct ids TAG-k have arrived or nothing new has for
 *       IDLE seconds, and prints one JSON line: distinct ids, duplicates, time of the last one, and with
 *       RATE > 0 the lag of each arrival behind its scheduled send time T + k / RATE (p50, p99, max).
 *
 * Both use reliable, volatile, keep-last DEPTH QoS. Errors go to stderr with exit status 1.
 */
#define _GNU_SOURCE
#include <errno.h>
#include <inttypes.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <time.h>

#include <rcl/error_handling.h>
#include <rcl/rcl.h>
#include <rmw/serialized_message.h>

#include "grasp_orient/msg/grasp_candidate.h"
#include "grasp_orient/msg/grip_recommendation.h"

#define DIGITS 8

static void die(const char *what)
{
    fprintf(stderr, "grasp_orient_rcl_peer: %s: %s\n", what,
            rcl_error_is_set() ? rcl_get_error_string().str : strerror(errno));
    exit(1);
}

static void check(rcl_ret_t ret, const char *what)
{
    if (ret != RCL_RET_OK) {
        die(what);
    }
}

static double now_s(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static void sleep_until(double t)
{
    struct timespec ts;
    ts.tv_sec = (time_t)floor(t);
    ts.tv_nsec = (long)((t - floor(t)) * 1e9);
    while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, NULL) == EINTR) {
    }
}

static double cpu_s(void)
{
    struct rusage ru;
    getrusage(RUSAGE_SELF, &ru);
    return (double)ru.ru_utime.tv_sec + 1e-6 * (double)ru.ru_utime.tv_usec + (double)ru.ru_stime.tv_sec +
           1e-6 * (double)ru.ru_stime.tv_usec;
}

static uint32_t read_u32(const uint8_t *p, int little)
{
    return little ? (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24
                  : (uint32_t)p[3] | (uint32_t)p[2] << 8 | (uint32_t)p[1] << 16 | (uint32_t)p[0] << 24;
}

/* The id (GraspCandidate.id, GripRecommendation.candidate_id: the string after the header) in a
 * serialized message: offset of its first character and its length without the NUL; -1 when the
 * buffer is too short. */
static long id_offset(const uint8_t *buf, size_t len, size_t *id_len)
{
    if (len < 4 + 8 + 4) {
        return -1;
    }
    int little = buf[1] == 1;
    size_t o = 4 + 8;                   /* encapsulation, stamp */
    o += 4 + read_u32(buf + o, little); /* frame_id */
    o = 4 + ((o - 4 + 3) & ~(size_t)3); /* align 4 from the start of the data */
    if (o + 4 > len) {
        return -1;
    }
    uint32_t n = read_u32(buf + o, little);
    if (n == 0 || o + 4 + n > len) {
        return -1;
    }
    *id_len = n - 1;
    return (long)(o + 4);
}

/* The number k of an id "TAG-dddddddd", or -1 for any other id. */
static long id_number(const uint8_t *buf, size_t len, const char *tag)
{
    size_t n;
    long o = id_offset(buf, len, &n);
    size_t t = strlen(tag);
    if (o < 0 || n != t + 1 + DIGITS || memcmp(buf + o, tag, t) != 0 || buf[o + (long)t] != '-') {
        return -1;
    }
    long k = 0;
    for (size_t i = 0; i < DIGITS; i++) {
        uint8_t c = buf[(size_t)o + t + 1 + i];
        if (c < '0' || c > '9') {
            return -1;
        }
        k = 10 * k + (c - '0');
    }
    return k;
}

static rmw_qos_profile_t qos(size_t depth)
{
    rmw_qos_profile_t q = rmw_qos_profile_default;
    q.history = RMW_QOS_POLICY_HISTORY_KEEP_LAST;
    q.depth = depth;
    q.reliability = RMW_QOS_POLICY_RELIABILITY_RELIABLE;
    q.durability = RMW_QOS_POLICY_DURABILITY_VOLATILE;
    return q;
}

typedef struct {
    rcl_context_t context;
    rcl_node_t node;
} Ros;

static void ros_init(Ros *ros, const char *name)
{
    rcl_allocator_t alloc = rcl_get_default_allocator();
    rcl_init_options_t options = rcl_get_zero_initialized_init_options();
    check(rcl_init_options_init(&options, alloc), "rcl_init_options_init");
    ros->context = rcl_get_zero_initialized_context();
    check(rcl_init(0, NULL, &options, &ros->context), "rcl_init");
    check(rcl_init_options_fini(&options), "rcl_init_options_fini");
    ros->node = rcl_get_zero_initialized_node();
    rcl_node_options_t node_options = rcl_node_get_default_options();
    check(rcl_node_init(&ros->node, name, "", &ros->context, &node_options), "rcl_node_init");
}

static void ros_fini(Ros *ros)
{
    rcl_node_fini(&ros->node);
    rcl_shutdown(&ros->context);
    rcl_context_fini(&ros->context);
}

/* Reads one line from stdin into line (at most size bytes); 0 at EOF. */
static int read_line(char *line, size_t size)
{
    if (fgets(line, (int)size, stdin) == NULL) {
        return 0;
    }
    return 1;
}

/* Matched endpoints on the other side of a publisher or a subscription. */
static size_t publisher_matched(const void *endpoint)
{
    size_t n = 0;
    check(rcl_publisher_get_subscription_count(endpoint, &n), "rcl_publisher_get_subscription_count");
    return n;
}

static size_t subscription_matched(const void *endpoint)
{
    size_t n = 0;
    check(rcl_subscription_get_publisher_count(endpoint, &n), "rcl_subscription_get_publisher_count");
    return n;
}

/* Waits up to 20 s for `endpoint` to match a `other` on `topic`, then prints "ready"; 0 on timeout. */
static int announce_when_matched(size_t (*matched)(const void *), const void *endpoint, const char *other,
                                 const char *topic)
{
    for (double until = now_s() + 20; matched(endpoint) == 0;) {
        if (now_s() > until) {
            fprintf(stderr, "grasp_orient_rcl_peer: no %s on %s within 20 s\n", other, topic);
            return 0;
        }
        sleep_until(now_s() + 0.01);
    }
    printf("ready\n");
    fflush(stdout);
    return 1;
}

static void node_name(char *out, size_t size, const char *role, const char *tag)
{
    snprintf(out, size, "grasp_orient_bench_%s_", role);
    size_t n = strlen(out);
    for (const char *c = tag; *c && n + 1 < size; c++) {
        out[n++] = ((*c >= 'a' && *c <= 'z') || (*c >= 'A' && *c <= 'Z') || (*c >= '0' && *c <= '9')) ? *c : '_';
    }
    out[n] = 0;
}

static int run_pub(const char *topic, const char *pool_path, double rate, long count, const char *tag,
                   size_t depth)
{
    /* the pool */
    FILE *f = fopen(pool_path, "rb");
    if (f == NULL) {
        die(pool_path);
    }
    rcl_serialized_message_t *pool = NULL;
    long *id_at = NULL;
    size_t pool_n = 0;
    rcl_allocator_t alloc = rcl_get_default_allocator();
    for (;;) {
        uint8_t head[4];
        if (fread(head, 1, 4, f) != 4) {
            break;
        }
        uint32_t len = read_u32(head, 1);
        pool = realloc(pool, (pool_n + 1) * sizeof *pool);
        id_at = realloc(id_at, (pool_n + 1) * sizeof *id_at);
        if (pool == NULL || id_at == NULL) {
            die("out of memory");
        }
        pool[pool_n] = rmw_get_zero_initialized_serialized_message();
        check(rmw_serialized_message_init(&pool[pool_n], len, &alloc), "rmw_serialized_message_init");
        if (fread(pool[pool_n].buffer, 1, len, f) != len) {
            die("truncated pool file");
        }
        pool[pool_n].buffer_length = len;
        if (id_number(pool[pool_n].buffer, len, tag) != 0) {
            fprintf(stderr, "grasp_orient_rcl_peer: pool message %zu has no id %s-%0*d\n", pool_n, tag, DIGITS, 0);
            return 1;
        }
        size_t n;
        id_at[pool_n] = id_offset(pool[pool_n].buffer, len, &n) + (long)strlen(tag) + 1;
        pool_n++;
    }
    fclose(f);
    if (pool_n == 0) {
        fprintf(stderr, "grasp_orient_rcl_peer: empty pool %s\n", pool_path);
        return 1;
    }

    Ros ros;
    char name[128];
    node_name(name, sizeof name, "pub", tag);
    ros_init(&ros, name);
    rcl_publisher_t pub = rcl_get_zero_initialized_publisher();
    rcl_publisher_options_t options = rcl_publisher_get_default_options();
    options.qos = qos(depth);
    check(rcl_publisher_init(&pub, &ros.node, ROSIDL_GET_MSG_TYPE_SUPPORT(grasp_orient, msg, GraspCandidate), topic,
                             &options),
          "rcl_publisher_init");
    if (!announce_when_matched(publisher_matched, &pub, "subscription", topic)) {
        return 1;
    }

    char line[256];
    double start = 0;
    if (!read_line(line, sizeof line) || sscanf(line, "go %lf", &start) != 1) {
        fprintf(stderr, "grasp_orient_rcl_peer: expected 'go T' on stdin\n");
        return 1;
    }
    double cpu0 = cpu_s();
    sleep_until(start);
    double behind = 0;
    for (long k = 0; k < count; k++) {
        if (rate > 0) {
            double due = start + (double)k / rate;
            double t = now_s();
            if (t < due) {
                sleep_until(due);
            } else if (t - due > behind) {
                behind = t - due;
            }
        }
        rcl_serialized_message_t *m = &pool[(size_t)k % pool_n];
        char digits[DIGITS + 1];
        snprintf(digits, sizeof digits, "%0*ld", DIGITS, k);
        memcpy(m->buffer + id_at[(size_t)k % pool_n], digits, DIGITS);
        check(rcl_publish_serialized_message(&pub, m, NULL), "rcl_publish_serialized_message");
    }
    double published = now_s();
    rcl_ret_t acked = rcl_publisher_wait_for_all_acked(&pub, RCL_S_TO_NS(60));
    double acked_at = now_s();
    printf("{\"published\": %ld, \"publish_s\": %.6f, \"acked\": %s, \"acked_s\": %.6f, \"behind_max_s\": %.6f, "
           "\"cpu_s\": %.3f}\n",
           count, published - start, acked == RCL_RET_OK ? "true" : "false", acked_at - start, behind,
           cpu_s() - cpu0);
    fflush(stdout);
    read_line(line, sizeof line);
    rcl_publisher_fini(&pub, &ros.node);
    ros_fini(&ros);
    return 0;
}

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

static int run_sub(const char *topic, const char *type, long count, const char *tag, double idle, size_t depth)
{
    const rosidl_message_type_support_t *ts;
    if (strcmp(type, "candidate") == 0) {
        ts = ROSIDL_GET_MSG_TYPE_SUPPORT(grasp_orient, msg, GraspCandidate);
    } else if (strcmp(type, "recommendation") == 0) {
        ts = ROSIDL_GET_MSG_TYPE_SUPPORT(grasp_orient, msg, GripRecommendation);
    } else {
        fprintf(stderr, "grasp_orient_rcl_peer: TYPE is candidate or recommendation, not %s\n", type);
        return 1;
    }
    Ros ros;
    char name[128];
    node_name(name, sizeof name, "sub", tag);
    ros_init(&ros, name);
    rcl_subscription_t sub = rcl_get_zero_initialized_subscription();
    rcl_subscription_options_t options = rcl_subscription_get_default_options();
    options.qos = qos(depth);
    check(rcl_subscription_init(&sub, &ros.node, ts, topic, &options), "rcl_subscription_init");
    if (!announce_when_matched(subscription_matched, &sub, "publisher", topic)) {
        return 1;
    }
    char line[256];
    double start = 0, rate = 0;
    if (!read_line(line, sizeof line) || sscanf(line, "go %lf %lf", &start, &rate) != 2) {
        fprintf(stderr, "grasp_orient_rcl_peer: expected 'go T RATE' on stdin\n");
        return 1;
    }

    rcl_allocator_t alloc = rcl_get_default_allocator();
    rcl_wait_set_t ws = rcl_get_zero_initialized_wait_set();
    check(rcl_wait_set_init(&ws, 1, 0, 0, 0, 0, 0, &ros.context, alloc), "rcl_wait_set_init");
    rcl_serialized_message_t msg = rmw_get_zero_initialized_serialized_message();
    check(rmw_serialized_message_init(&msg, 4096, &alloc), "rmw_serialized_message_init");
    uint8_t *seen = calloc((size_t)count, 1);
    double *lag = calloc((size_t)count, sizeof *lag);
    if (seen == NULL || lag == NULL) {
        die("out of memory");
    }
    long distinct = 0, duplicates = 0, other = 0;
    double last = 0, cpu0 = cpu_s(), deadline = start + idle + 60.0;
    while (distinct < count) {
        double t = now_s();
        if ((last > 0 && t - last > idle) || (last == 0 && t > deadline)) {
            break;
        }
        check(rcl_wait_set_clear(&ws), "rcl_wait_set_clear");
        check(rcl_wait_set_add_subscription(&ws, &sub, NULL), "rcl_wait_set_add_subscription");
        rcl_ret_t ret = rcl_wait(&ws, RCL_MS_TO_NS(50));
        if (ret == RCL_RET_TIMEOUT) {
            continue;
        }
        check(ret, "rcl_wait");
        for (;;) {
            rmw_message_info_t info = rmw_get_zero_initialized_message_info();
            ret = rcl_take_serialized_message(&sub, &msg, &info, NULL);
            if (ret == RCL_RET_SUBSCRIPTION_TAKE_FAILED) {
                break;
            }
            check(ret, "rcl_take_serialized_message");
            double at = now_s();
            long k = id_number(msg.buffer, msg.buffer_length, tag);
            if (k < 0 || k >= count) {
                other++;
                continue;
            }
            if (seen[k]) {
                duplicates++;
                continue;
            }
            seen[k] = 1;
            lag[distinct++] = rate > 0 ? at - (start + (double)k / rate) : 0;
            last = at;
        }
    }
    double used = cpu_s() - cpu0;
    qsort(lag, (size_t)distinct, sizeof *lag, cmp_double);
    double p50 = distinct ? lag[(size_t)(0.50 * (double)(distinct - 1))] : NAN;
    double p99 = distinct ? lag[(size_t)(0.99 * (double)(distinct - 1))] : NAN;
    double mx = distinct ? lag[distinct - 1] : NAN;
    printf("{\"received\": %ld, \"duplicates\": %ld, \"other\": %ld, \"last_s\": %.6f, \"lag_p50_ms\": %.3f, "
           "\"lag_p99_ms\": %.3f, \"lag_max_ms\": %.3f, \"cpu_s\": %.3f}\n",
           distinct, duplicates, other, distinct ? last - start : NAN, 1e3 * p50, 1e3 * p99, 1e3 * mx, used);
    fflush(stdout);
    free(seen);
    free(lag);
    rmw_serialized_message_fini(&msg);
    rcl_wait_set_fini(&ws);
    rcl_subscription_fini(&sub, &ros.node);
    ros_fini(&ros);
    return 0;
}

int main(int argc, char **argv)
{
    if (argc == 8 && strcmp(argv[1], "pub") == 0) {
        return run_pub(argv[2], argv[3], atof(argv[4]), atol(argv[5]), argv[6], (size_t)atol(argv[7]));
    }
    if (argc == 8 && strcmp(argv[1], "sub") == 0) {
        return run_sub(argv[2], argv[3], atol(argv[4]), argv[5], atof(argv[6]), (size_t)atol(argv[7]));
    }
    fprintf(stderr, "usage: %s pub TOPIC POOL RATE COUNT TAG DEPTH\n"
                    "       %s sub TOPIC candidate|recommendation COUNT TAG IDLE DEPTH\n",
            argv[0], argv[0]);
    return 2;
}
