/* test_error.c — sg_error messages: a message longer than the buffer keeps
 * its head (the file) and its tail (the fault). */
#include "test_support.h"

#include <stdlib.h>
#include <string.h>

#include "core/error.h"

/* A 5 MB path: the message must still end with what went wrong. */
static void test_error_long_message_keeps_head_and_tail(void **state)
{
    (void)state;
    size_t n = 5u << 20;
    char *path = malloc(n + 1);
    assert_non_null(path);
    memset(path, 'a', n);
    memcpy(path, "/scans/", 7);
    memcpy(path + n - 9, "model.plx", 9);
    path[n] = '\0';
    sg_error err = {0};
    assert_int_equal(sg_error_set(&err, SG_ERR_IO, "%s: cannot open: No such file or directory", path), SG_ERR_IO);
    size_t len = strlen(err.message);
    assert_true(len < SG_ERROR_MESSAGE_MAX);
    assert_true(len > SG_ERROR_MESSAGE_MAX / 2); /* the buffer is used, not a stub */
    assert_memory_equal(err.message, "/scans/aaa", 10);
    const char *tail = "model.plx: cannot open: No such file or directory";
    if (len < strlen(tail) || strcmp(err.message + len - strlen(tail), tail) != 0)
        fail_msg("message lost its tail: \"%s\"", err.message);
    assert_non_null(strstr(err.message, "..."));
    free(path);
}

/* A message that fits is kept whole, byte for byte. */
static void test_error_short_message_unchanged(void **state)
{
    (void)state;
    sg_error err = {0};
    sg_error_set(&err, SG_ERR_CORRUPT, "bunny.ply: vertex %d: radius is NaN", 1042);
    assert_string_equal(err.message, "bunny.ply: vertex 1042: radius is NaN");
    assert_int_equal(err.status, SG_ERR_CORRUPT);
    /* Exactly the buffer size minus the NUL: still whole. */
    char fill[SG_ERROR_MESSAGE_MAX];
    memset(fill, 'x', sizeof fill - 1);
    fill[sizeof fill - 1] = '\0';
    sg_error_set(&err, SG_ERR_IO, "%s", fill);
    assert_string_equal(err.message, fill);
}

/* The cut never splits a UTF-8 sequence: the message stays valid UTF-8. */
static void test_error_cut_keeps_utf8_whole(void **state)
{
    (void)state;
    char big[3 * SG_ERROR_MESSAGE_MAX];
    size_t j = 0;
    while (j + 2 < sizeof big - 1) { /* "é" (C3 A9) repeated */
        big[j++] = (char)0xC3;
        big[j++] = (char)0xA9;
    }
    big[j] = '\0';
    sg_error err = {0};
    sg_error_set(&err, SG_ERR_IO, "%s: end", big);
    const unsigned char *s = (const unsigned char *)err.message;
    for (size_t i = 0; s[i]; ++i) {
        if (s[i] == 0xC3) {
            if (s[i + 1] != 0xA9)
                fail_msg("lead byte at %zu without its continuation", i);
            ++i;
        } else if (s[i] == 0xA9) {
            fail_msg("continuation byte at %zu without its lead", i);
        }
    }
    size_t len = strlen(err.message);
    assert_string_equal(err.message + len - 5, ": end");
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_error_long_message_keeps_head_and_tail),
        cmocka_unit_test(test_error_short_message_unchanged),
        cmocka_unit_test(test_error_cut_keeps_utf8_whole),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
