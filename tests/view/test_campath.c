/* test_campath.c — camera path files (view/campath.h).
 *   1. write/read round trip gives back every value bit for bit
 *   2. malformed lines: the message names the file and the line
 *   3. comments, blank lines and CRLF are accepted
 *   4. playback index: the last key at or before t
 *   5. append checks keys like the reader does
 */
#include "test_support.h"

#include <stdio.h>
#include <string.h>

#include "view/campath.h"

/* 1 */
static void test_round_trip(void **state)
{
    (void)state;
    sg_campath p = {0};
    sg_error err;
    uint64_t rng = 3;
    double t = 0.0;
    for (int i = 0; i < 300; i++) {
        sg_campath_key k;
        t += 1.0 / 60.0 + 1e-3 * sg_test_rand01(&rng);
        k.time = t;
        k.view.eye = sg_v3(100.0f * sg_test_rand01(&rng) - 50.0f, 1e-7f * sg_test_rand01(&rng), 3.14159f);
        k.view.look = sg_v3(sg_test_rand01(&rng), 1e6f * sg_test_rand01(&rng) + 100.0f, -7.5f);
        k.view.up = sg_v3(0.0f, 1.0f, 0.0f);
        k.view.fov_deg = 10.0f + 100.0f * sg_test_rand01(&rng);
        assert_int_equal(sg_campath_append(&p, &k, &err), SG_OK);
    }
    char path[1024];
    snprintf(path, sizeof path, "%s/walk.txt", sg_test_tmpdir());
    assert_int_equal(sg_campath_write(&p, path, &err), SG_OK);
    sg_campath q = {0};
    assert_int_equal(sg_campath_read(path, &q, &err), SG_OK);
    assert_int_equal(q.count, p.count);
    for (size_t i = 0; i < p.count; i++) {
        assert_memory_equal(&q.keys[i].time, &p.keys[i].time, sizeof(double));
        assert_memory_equal(&q.keys[i].view, &p.keys[i].view, sizeof(sg_nav_view));
    }
    /* writing again gives the same bytes */
    char path2[1024];
    snprintf(path2, sizeof path2, "%s/walk2.txt", sg_test_tmpdir());
    assert_int_equal(sg_campath_write(&q, path2, &err), SG_OK);
    FILE *a = fopen(path, "rb"), *b = fopen(path2, "rb");
    assert_non_null(a);
    assert_non_null(b);
    int ca, cb;
    do {
        ca = fgetc(a);
        cb = fgetc(b);
        assert_int_equal(ca, cb);
    } while (ca != EOF);
    fclose(a);
    fclose(b);
    sg_campath_free(&p);
    sg_campath_free(&q);
    assert_null(p.keys);
}

static void expect_error(const char *text, sg_status status, const char *message)
{
    const char *path = sg_test_write_file("walk.txt", text, strlen(text));
    sg_campath p = {0};
    sg_error err;
    assert_int_equal(sg_campath_read(path, &p, &err), status);
    assert_null(p.keys);
    char want[1024];
    snprintf(want, sizeof want, "%s%s", path, message);
    if (strcmp(err.message, want))
        fprintf(stderr, "got  '%s'\nwant '%s'\n", err.message, want);
    assert_string_equal(err.message, want);
}

/* 2 */
static void test_malformed(void **state)
{
    (void)state;
    const char *ok = "0 0 1 5 0 0 0 0 1 0 40\n";
    char text[512];
    snprintf(text, sizeof text, "# header\n%s0 1 2 3 4 5 6\n", ok);
    expect_error(text, SG_ERR_CORRUPT, ":3: expected 11 numbers (time eye.xyz look.xyz up.xyz fov), got 7");
    snprintf(text, sizeof text, "%s1 0 1 abc 0 0 0 0 1 0 40\n", ok);
    expect_error(text, SG_ERR_CORRUPT, ":2: number 4: 'abc' is not a number");
    snprintf(text, sizeof text, "%s%s1 0 1 5 0 0 0 0 1 0 200\n", ok, ok);
    expect_error(text, SG_ERR_CORRUPT, ":3: fov 200 is not in (0, 180)");
    expect_error("1 0 1 5 0 0 0 0 1 0 40\n0.5 0 1 5 0 0 0 0 1 0 40\n", SG_ERR_CORRUPT,
                 ":2: time 0.5 is before the previous key's 1");
    expect_error("0 1 1 1 1 1 1 0 1 0 40\n", SG_ERR_CORRUPT, ":1: look equals eye");
    expect_error("0 0 5 0 0 0 0 0 1 0 40\n", SG_ERR_CORRUPT, ":1: up is parallel to look - eye (or zero)");
    expect_error("0 nan 1 5 0 0 0 0 1 0 40\n", SG_ERR_CORRUPT, ":1: a number is not finite");
    expect_error("0 0 1 5 0 0 0 0 1 0 40 7\n", SG_ERR_CORRUPT,
                 ":1: expected 11 numbers (time eye.xyz look.xyz up.xyz fov), got 12");
    expect_error("# nothing\n\n", SG_ERR_CORRUPT, ": no camera keys");
    sg_campath p = {0};
    sg_error err;
    char missing[1024];
    snprintf(missing, sizeof missing, "%s/none.txt", sg_test_tmpdir());
    assert_int_equal(sg_campath_read(missing, &p, &err), SG_ERR_IO);
    assert_non_null(strstr(err.message, "none.txt"));
}

/* 3 */
static void test_comments_and_crlf(void **state)
{
    (void)state;
    const char *text = "  # a comment\r\n\r\n\t0 0 1 5\t0 0 0 0 1 0 40\r\n   \n0.5 0 1 4 0 0 0 0 1 0 41";
    sg_campath p = {0};
    sg_error err;
    assert_int_equal(sg_campath_parse(text, strlen(text), "x", &p, &err), SG_OK);
    assert_int_equal(p.count, 2);
    assert_true(p.keys[1].time == 0.5 && p.keys[1].view.eye.z == 4.0f && p.keys[1].view.fov_deg == 41.0f);
    sg_campath_free(&p);
}

/* 4 */
static void test_index_at(void **state)
{
    (void)state;
    const char *text = "0 0 1 5 0 0 0 0 1 0 40\n1 0 1 5 0 0 0 0 1 0 40\n1 0 1 5 0 0 0 0 1 0 40\n"
                       "2 0 1 5 0 0 0 0 1 0 40\n";
    sg_campath p = {0};
    sg_error err;
    assert_int_equal(sg_campath_parse(text, strlen(text), "x", &p, &err), SG_OK);
    assert_int_equal(sg_campath_index_at(&p, -1.0), 0);
    assert_int_equal(sg_campath_index_at(&p, 0.0), 0);
    assert_int_equal(sg_campath_index_at(&p, 0.99), 0);
    assert_int_equal(sg_campath_index_at(&p, 1.0), 2);
    assert_int_equal(sg_campath_index_at(&p, 1.5), 2);
    assert_int_equal(sg_campath_index_at(&p, 2.0), 3);
    assert_int_equal(sg_campath_index_at(&p, 99.0), 3);
    sg_camera cam;
    assert_int_equal(sg_campath_camera(&p.keys[0], 2.0f, &cam, &err), SG_OK);
    assert_true(cam.aspect == 2.0f);
    sg_campath_free(&p);
}

/* 5 */
static void test_append_checks(void **state)
{
    (void)state;
    sg_campath p = {0};
    sg_error err;
    sg_campath_key k = {1.0, {{0, 1, 5}, {0, 0, 0}, {0, 1, 0}, 40.0f}};
    assert_int_equal(sg_campath_append(&p, &k, &err), SG_OK);
    k.time = 0.5;
    assert_int_equal(sg_campath_append(&p, &k, &err), SG_ERR_INVALID_ARG);
    k.time = 2.0;
    k.view.fov_deg = 0.0f;
    assert_int_equal(sg_campath_append(&p, &k, &err), SG_ERR_INVALID_ARG);
    assert_int_equal(p.count, 1);
    sg_campath_free(&p);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_round_trip), cmocka_unit_test(test_malformed),
        cmocka_unit_test(test_comments_and_crlf), cmocka_unit_test(test_index_at),
        cmocka_unit_test(test_append_checks),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
