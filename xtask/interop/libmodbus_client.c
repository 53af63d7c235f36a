/*
 * A small libmodbus client for `cargo xtask interop`: reads and writes 16-bit parameters of a
 * Bonfiglioli ACTIVE drive (or anything that answers like one) with function codes 3 and 6 over
 * Modbus RTU, 19200 baud, 8N1, and checks the exception answers of the manual
 * (bonfiglioli-active-modbus-de.txt ch. 6.4-6.6, 7, 8.1).
 *
 *   libmodbus_client PORT [ADDRESS]
 *
 * Prints one line per check, "PASS libmodbus: <what> (<compared>)" or "FAIL libmodbus: ...",
 * and exits 1 when any check failed, 2 when the port cannot be opened.
 *
 * Start address = data set << 12 | parameter (ch. 6.4.1: 372 in data set 2 = 0x2174).
 */
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <modbus.h>

static int failures;

static unsigned addr_of(unsigned parameter, unsigned data_set) { return data_set << 12 | parameter; }

static void report(int ok, const char *what, const char *compared) {
    printf("%s libmodbus: %s (%s)\n", ok ? "PASS" : "FAIL", what, compared);
    fflush(stdout);
    if (!ok) failures++;
}

/* The exception code of the last failed call, 0 when errno is not a Modbus exception. */
static int exception_of(int err) {
    switch (err) {
    case EMBXILFUN: return 1;
    case EMBXILADD: return 2;
    case EMBXILVAL: return 3;
    case EMBXSFAIL: return 4;
    default: return 0;
    }
}

static void expect_read(modbus_t *ctx, unsigned parameter, unsigned data_set, int expected,
                        const char *what) {
    uint16_t value = 0;
    char compared[160];
    if (modbus_read_registers(ctx, (int)addr_of(parameter, data_set), 1, &value) != 1) {
        snprintf(compared, sizeof compared, "FC 3 0x%04X: expected %d, got error: %s",
                 addr_of(parameter, data_set), expected, modbus_strerror(errno));
        report(0, what, compared);
        return;
    }
    snprintf(compared, sizeof compared, "FC 3 0x%04X: expected %d, got %u",
             addr_of(parameter, data_set), expected, value);
    report(value == expected, what, compared);
}

static void expect_write(modbus_t *ctx, unsigned parameter, unsigned data_set, uint16_t value,
                         const char *what) {
    char compared[160];
    int rc = modbus_write_register(ctx, (int)addr_of(parameter, data_set), value);
    snprintf(compared, sizeof compared, "FC 6 0x%04X = %u: %s", addr_of(parameter, data_set),
             value, rc == 1 ? "echo received" : modbus_strerror(errno));
    report(rc == 1, what, compared);
}

/* rc is the return value of the call, err its errno. */
static void expect_exception(int rc, int err, int expected, const char *request, const char *what) {
    char compared[200];
    int got = rc == -1 ? exception_of(err) : 0;
    snprintf(compared, sizeof compared, "%s: expected exception %d, got %s%s", request, expected,
             rc == -1 ? "" : "a normal answer", rc == -1 ? modbus_strerror(err) : "");
    report(got == expected, what, compared);
}

int main(int argc, char **argv) {
    if (argc < 2 || argc > 3) {
        fprintf(stderr, "usage: %s PORT [ADDRESS]\n", argv[0]);
        return 2;
    }
    int slave = argc == 3 ? atoi(argv[2]) : 1;
    modbus_t *ctx = modbus_new_rtu(argv[1], 19200, 'N', 8, 1);
    if (ctx == NULL || modbus_set_slave(ctx, slave) == -1) {
        fprintf(stderr, "libmodbus: cannot set up RTU on %s: %s\n", argv[1], modbus_strerror(errno));
        return 2;
    }
    modbus_set_response_timeout(ctx, 1, 0);
    if (modbus_connect(ctx) == -1) {
        fprintf(stderr, "libmodbus: cannot open %s: %s\n", argv[1], modbus_strerror(errno));
        modbus_free(ctx);
        return 2;
    }

    uint16_t regs[2];
    int rc;

    /* ch. 8.1.1 example 1 and 8.1.2 example 1, as FC 6 then FC 3 */
    expect_write(ctx, 372, 2, 1450, "write rated speed 372 data set 2 = 1450 1/min");
    expect_read(ctx, 372, 2, 1450, "read back 372 data set 2");
    expect_write(ctx, 372, 2, 1390, "write 372 data set 2 = 1390 1/min");
    expect_read(ctx, 372, 2, 1390, "read rated speed 372 data set 2 (ch. 8.1.1: 1390 1/min)");
    expect_write(ctx, 376, 4, 15, "write mech. rated power 376 data set 4 = 1.5 kW");
    expect_read(ctx, 376, 4, 15, "read back 376 data set 4");
    expect_write(ctx, 376, 9, 16, "write 376 data set 9 (RAM copy of data set 4)");
    expect_read(ctx, 376, 4, 16, "read 376 data set 4 after the RAM write");

    /* ch. 8.1.2 example 2: value 0 refused with exception 4, cause in VABus register 11 */
    rc = modbus_write_register(ctx, (int)addr_of(376, 2), 0);
    expect_exception(rc, errno, 4, "FC 6 0x2178 = 0", "write 0 to 376 refused");
    expect_read(ctx, 11, 0, 1, "VABus error register 11 after it (1, invalid value)");
    expect_read(ctx, 11, 0, 0, "VABus error register 11 read again (cleared by reading)");

    /* ch. 8.1.1 example 2: register count 2 */
    rc = modbus_read_registers(ctx, (int)addr_of(372, 0), 2, regs);
    expect_exception(rc, errno, 2, "FC 3 0x0174 count 2", "register count 2 refused");

    /* ch. 8.1.3 example 2 (there with FC 100): unknown parameter 1600 */
    rc = modbus_read_registers(ctx, (int)addr_of(1600, 2), 1, regs);
    expect_exception(rc, errno, 4, "FC 3 0x2640", "unknown parameter 1600 refused");
    expect_read(ctx, 11, 0, 11, "VABus error register 11 after it (11, unknown parameter)");

    /* ch. 7: data set 0 writes all four; reading it fails (VABus error 9) when they differ */
    expect_write(ctx, 372, 0, 1400, "write 372 data set 0 (all four data sets)");
    expect_read(ctx, 372, 3, 1400, "read 372 data set 3 after it");
    expect_read(ctx, 372, 0, 1400, "read 372 data set 0 (all four equal)");
    expect_write(ctx, 372, 1, 1390, "write 372 data set 1 only");
    rc = modbus_read_registers(ctx, (int)addr_of(372, 0), 1, regs);
    expect_exception(rc, errno, 4, "FC 3 0x0174", "read 372 data set 0 with differing data sets");
    expect_read(ctx, 11, 0, 9, "VABus error register 11 after it (9, data sets differ)");
    expect_write(ctx, 372, 0, 1390, "write 372 data set 0 back to 1390");

    modbus_close(ctx);
    modbus_free(ctx);
    return failures ? 1 : 0;
}
