/* bake_mpi.c — bake_mpi.h with MPI (built when CMake finds MPI and SG_MPI
 * is on). Every MPI call of splatgi lives in this file.
 *
 * The exchange (bake/bake_comm.h) in two steps: an MPI_Allgather of each
 * rank's (byte count, stop flag), then one MPI_Bcast per rank of its bytes
 * into its place of the concatenation, in chunks below INT_MAX bytes (MPI
 * counts are ints). No MPI reduction touches a floating-point value: the
 * stop flags are combined here from the gathered integers, and the bake's
 * values are only concatenated, so rank count cannot change a bit.
 *
 * Invariant: every rank calls the exchange the same number of times (the
 * job's rounds depend only on the shared state and the combined stop
 * flags); a rank that cannot go on calls sg_mpi_abort, which ends all.
 */
#include "bake_mpi.h"

#include <mpi.h>
#include <signal.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/alloc.h"

enum { CHUNK = 1 << 30 }; /* bytes per MPI_Bcast */

static sg_status mpi_fail(int code, const char *what, sg_error *err)
{
    char msg[MPI_MAX_ERROR_STRING];
    int len = 0;
    if (MPI_Error_string(code, msg, &len) != MPI_SUCCESS)
        snprintf(msg, sizeof msg, "MPI error %d", code);
    return sg_error_set(err, SG_ERR_IO, "MPI: %s: %s", what, msg);
}

static sg_status exchange(void *user, const void *mine, size_t bytes, void **all, size_t *all_bytes, int *stop,
                          sg_error *err)
{
    sg_mpi *m = user;
    ++m->exchanges;
    if (m->rank == m->fault_rank && m->exchanges == m->fault_at) {
        if (m->fault_kind == SG_MPI_FAULT_KILL)
            raise(SIGKILL);
        if (m->fault_kind == SG_MPI_FAULT_INT)
            raise(SIGINT); /* as Ctrl-C reaching this rank alone; the exchange goes on */
        else
            return sg_error_set(err, SG_ERR_IO, "MPI: exchange %ld failed (SPLATGI_MPI_FAULT)", m->exchanges);
    }
    double t0 = MPI_Wtime();
    uint64_t own[2] = {bytes, *stop != 0}, *each = sg_alloc_array((size_t)m->size, sizeof own);
    if (!each)
        return sg_error_set(err, SG_ERR_NOMEM, "MPI: out of memory");
    int rc = MPI_Allgather(own, 2, MPI_UINT64_T, each, 2, MPI_UINT64_T, MPI_COMM_WORLD);
    if (rc != MPI_SUCCESS) {
        sg_free(each);
        return mpi_fail(rc, "gathering the sizes of a round", err);
    }
    size_t total = 0;
    int any_stop = 0;
    for (int r = 0; r < m->size; ++r) {
        total += (size_t)each[2 * r];
        any_stop |= each[2 * r + 1] != 0;
    }
    unsigned char *buf = total ? sg_alloc_array(total, 1) : NULL;
    if (total && !buf) {
        sg_free(each);
        return sg_error_set(err, SG_ERR_NOMEM, "MPI: out of memory for a round of %zu bytes", total);
    }
    size_t at = 0;
    for (int r = 0; r < m->size && rc == MPI_SUCCESS; ++r) {
        size_t n = (size_t)each[2 * r];
        if (r == m->rank && n)
            memcpy(buf + at, mine, n);
        for (size_t off = 0; off < n && rc == MPI_SUCCESS; off += CHUNK) {
            size_t c = n - off < CHUNK ? n - off : CHUNK;
            rc = MPI_Bcast(buf + at + off, (int)c, MPI_BYTE, r, MPI_COMM_WORLD);
        }
        at += n;
    }
    sg_free(each);
    if (rc != MPI_SUCCESS) {
        sg_free(buf);
        return mpi_fail(rc, "sending a round's results", err);
    }
    *all = buf;
    *all_bytes = total;
    *stop = any_stop;
    m->sent += (double)bytes;
    m->received += (double)(total - bytes);
    m->seconds += MPI_Wtime() - t0;
    return SG_OK;
}

/* SPLATGI_MPI_FAULT=RANK:N:error|kill|int (bake_mpi.h). */
static int parse_fault(const char *s, sg_mpi *m)
{
    char kind[16];
    int n = 0;
    if (sscanf(s, "%d:%ld:%15[a-z]%n", &m->fault_rank, &m->fault_at, kind, &n) != 3 || s[n] || m->fault_rank < 0 ||
        m->fault_at < 1 || (strcmp(kind, "error") && strcmp(kind, "kill") && strcmp(kind, "int"))) {
        fprintf(stderr, "splatgi-bake: SPLATGI_MPI_FAULT='%s' is not RANK:N:error, RANK:N:kill or RANK:N:int\n", s);
        return 1;
    }
    m->fault_kind = !strcmp(kind, "kill") ? SG_MPI_FAULT_KILL : !strcmp(kind, "int") ? SG_MPI_FAULT_INT
                                                                                     : SG_MPI_FAULT_ERROR;
    return 0;
}

int sg_mpi_start(int *argc, char ***argv, sg_mpi *m)
{
    memset(m, 0, sizeof *m);
    m->size = 1;
    m->fault_rank = -1;
    snprintf(m->library, sizeof m->library, "none");
    const char *fault = getenv("SPLATGI_MPI_FAULT");
    if (fault && *fault && parse_fault(fault, m))
        return 1;
    if (!getenv("OMPI_COMM_WORLD_SIZE") && !getenv("PMI_SIZE") && !getenv("PMIX_RANK"))
        return 0; /* not launched by mpirun: a plain run, MPI untouched */
    int rc = MPI_Init(argc, argv);
    if (rc != MPI_SUCCESS) {
        fprintf(stderr, "splatgi-bake: MPI_Init failed (error %d)\n", rc);
        return 1;
    }
    /* Errors come back as codes (reported with the rank), not as the
     * default handler's abort. */
    MPI_Comm_set_errhandler(MPI_COMM_WORLD, MPI_ERRORS_RETURN);
    MPI_Comm_rank(MPI_COMM_WORLD, &m->rank);
    MPI_Comm_size(MPI_COMM_WORLD, &m->size);
    char lib[MPI_MAX_LIBRARY_VERSION_STRING];
    int len = 0;
    if (MPI_Get_library_version(lib, &len) == MPI_SUCCESS) {
        lib[strcspn(lib, ",\n")] = '\0'; /* "Open MPI v4.1.4, package: ..." */
        snprintf(m->library, sizeof m->library, "%.63s", lib);
    }
    m->active = 1;
    m->comm = (sg_bake_comm){.rank = m->rank, .size = m->size, .exchange = exchange, .user = m};
    return 0;
}

void sg_mpi_abort(const sg_mpi *m, int code)
{
    fflush(stdout);
    fflush(stderr);
    if (m->active)
        MPI_Abort(MPI_COMM_WORLD, code);
    exit(code);
}

int sg_mpi_finish(sg_mpi *m, int rc)
{
    if (m->active)
        MPI_Finalize();
    m->active = 0;
    return rc;
}
