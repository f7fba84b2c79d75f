/*
 * Object dictionary of the SOES port, in the form SOES's EEPROM generator writes it
 * (compare soes/applications/linux_lan9252demo/slave_objectlist.c). The identity and the
 * PDOs match tests/soes/esi/soes-analog-io.xml.
 */
#include "esc_coe.h"
#include "utypes.h"
#include <stddef.h>

#define VENDOR_ID        0x00000000 /* placeholder, as the project's own module */
#define PRODUCT_CODE     0x534F4553 /* "SOES" */
#define REVISION         0x00000001
#define DEVICE_NAME      "SOES analog I/O"
#define DEVICE_NAME_BITS (8 * (sizeof (DEVICE_NAME) - 1))
#define HW_REV           "1.0"
#define SW_REV           "SOES 6ef7b94"
#define SW_REV_BITS      (8 * (sizeof (SW_REV) - 1))
/* The shortest SYNC0 cycle the port accepts (0x1C32:05, 0x1C33:05; dc_checker in main.c). */
#define MIN_CYCLE_TIME_NS 100000

static const char acName1000[] = "Device Type";
static const char acName1008[] = "Device Name";
static const char acName1009[] = "Hardware Version";
static const char acName100A[] = "Software Version";
static const char acName1018[] = "Identity Object";
static const char acName1018_00[] = "Max SubIndex";
static const char acName1018_01[] = "Vendor ID";
static const char acName1018_02[] = "Product Code";
static const char acName1018_03[] = "Revision Number";
static const char acName1018_04[] = "Serial Number";
static const char acName10F1[] = "Error Settings";
static const char acName10F1_00[] = "Max SubIndex";
static const char acName10F1_01[] = "Local Error Reaction";
static const char acName10F1_02[] = "Sync Error Counter Limit";
static const char acName1600[] = "AO RxPDO-Map";
static const char acName1600_00[] = "Max SubIndex";
static const char acName1600_01[] = "AO 1";
static const char acName1600_02[] = "AO 2";
static const char acName1A00[] = "AI TxPDO-Map";
static const char acName1A00_00[] = "Max SubIndex";
static const char acName1A00_01[] = "AI 1";
static const char acName1A00_02[] = "AI 2";
static const char acName1A00_03[] = "AI 3";
static const char acName1A00_04[] = "AI 4";
static const char acName1A00_05[] = "AI 5";
static const char acName1A00_06[] = "AI 6";
static const char acName1A00_07[] = "AI 7";
static const char acName1A00_08[] = "AI 8";
static const char acName1C00[] = "Sync Manager Communication Type";
static const char acName1C00_00[] = "Max SubIndex";
static const char acName1C00_01[] = "Communications Type SM0";
static const char acName1C00_02[] = "Communications Type SM1";
static const char acName1C00_03[] = "Communications Type SM2";
static const char acName1C00_04[] = "Communications Type SM3";
static const char acName1C12[] = "Sync Manager 2 PDO Assignment";
static const char acName1C12_00[] = "Max SubIndex";
static const char acName1C12_01[] = "PDO Mapping";
static const char acName1C13[] = "Sync Manager 3 PDO Assignment";
static const char acName1C13_00[] = "Max SubIndex";
static const char acName1C13_01[] = "PDO Mapping";
static const char acName1C32[] = "Sync Manager 2 Parameters";
static const char acName1C32_00[] = "Max SubIndex";
static const char acName1C32_01[] = "Sync mode";
static const char acName1C32_02[] = "CycleTime";
static const char acName1C32_04[] = "Sync modes supported";
static const char acName1C32_05[] = "Minimum Cycle Time";
static const char acName1C32_06[] = "Calc and Copy Time";
static const char acName1C32_0C[] = "Cycle Time Too Small";
static const char acName1C32_20[] = "Sync Error";
static const char acName1C33[] = "Sync Manager 3 Parameters";
static const char acName1C33_00[] = "Max SubIndex";
static const char acName1C33_01[] = "Sync mode";
static const char acName1C33_02[] = "CycleTime";
static const char acName1C33_04[] = "Sync modes supported";
static const char acName1C33_05[] = "Minimum Cycle Time";
static const char acName1C33_06[] = "Calc and Copy Time";
static const char acName1C33_0C[] = "Cycle Time Too Small";
static const char acName1C33_20[] = "Sync Error";
static const char acName6401[] = "Read Analog Input 16-bit";
static const char acName6401_00[] = "Max SubIndex";
static const char acName6401_01[] = "AI 1";
static const char acName6401_02[] = "AI 2";
static const char acName6401_03[] = "AI 3";
static const char acName6401_04[] = "AI 4";
static const char acName6401_05[] = "AI 5";
static const char acName6401_06[] = "AI 6";
static const char acName6401_07[] = "AI 7";
static const char acName6401_08[] = "AI 8";
static const char acName6411[] = "Write Analog Output 16-bit";
static const char acName6411_00[] = "Max SubIndex";
static const char acName6411_01[] = "AO 1";
static const char acName6411_02[] = "AO 2";

const _objd SDO1000[] =
{
  {0x0, DTYPE_UNSIGNED32, 32, ATYPE_RO, acName1000, 0x000C0191, NULL},
};
const _objd SDO1008[] =
{
  {0x0, DTYPE_VISIBLE_STRING, DEVICE_NAME_BITS, ATYPE_RO, acName1008, 0, DEVICE_NAME},
};
const _objd SDO1009[] =
{
  {0x0, DTYPE_VISIBLE_STRING, 24, ATYPE_RO, acName1009, 0, HW_REV},
};
const _objd SDO100A[] =
{
  {0x0, DTYPE_VISIBLE_STRING, SW_REV_BITS, ATYPE_RO, acName100A, 0, SW_REV},
};
const _objd SDO1018[] =
{
  {0x00, DTYPE_UNSIGNED8, 8, ATYPE_RO, acName1018_00, 4, NULL},
  {0x01, DTYPE_UNSIGNED32, 32, ATYPE_RO, acName1018_01, VENDOR_ID, NULL},
  {0x02, DTYPE_UNSIGNED32, 32, ATYPE_RO, acName1018_02, PRODUCT_CODE, NULL},
  {0x03, DTYPE_UNSIGNED32, 32, ATYPE_RO, acName1018_03, REVISION, NULL},
  {0x04, DTYPE_UNSIGNED32, 32, ATYPE_RO, acName1018_04, 0, NULL},
};
const _objd SDO10F1[] =
{
  {0x00, DTYPE_UNSIGNED8, 8, ATYPE_RO, acName10F1_00, 2, NULL},
  {0x01, DTYPE_UNSIGNED32, 32, ATYPE_RW, acName10F1_01, 0, &Obj.ErrorSettings.LocalErrorReaction},
  {0x02, DTYPE_UNSIGNED16, 16, ATYPE_RW, acName10F1_02, 4, &Obj.ErrorSettings.SyncErrorCounterLimit},
};
const _objd SDO1600[] =
{
  {0x00, DTYPE_UNSIGNED8, 8, ATYPE_RO, acName1600_00, 2, NULL},
  {0x01, DTYPE_UNSIGNED32, 32, ATYPE_RO, acName1600_01, 0x64110110, NULL},
  {0x02, DTYPE_UNSIGNED32, 32, ATYPE_RO, acName1600_02, 0x64110210, NULL},
};
const _objd SDO1A00[] =
{
  {0x00, DTYPE_UNSIGNED8, 8, ATYPE_RO, acName1A00_00, 8, NULL},
  {0x01, DTYPE_UNSIGNED32, 32, ATYPE_RO, acName1A00_01, 0x64010110, NULL},
  {0x02, DTYPE_UNSIGNED32, 32, ATYPE_RO, acName1A00_02, 0x64010210, NULL},
  {0x03, DTYPE_UNSIGNED32, 32, ATYPE_RO, acName1A00_03, 0x64010310, NULL},
  {0x04, DTYPE_UNSIGNED32, 32, ATYPE_RO, acName1A00_04, 0x64010410, NULL},
  {0x05, DTYPE_UNSIGNED32, 32, ATYPE_RO, acName1A00_05, 0x64010510, NULL},
  {0x06, DTYPE_UNSIGNED32, 32, ATYPE_RO, acName1A00_06, 0x64010610, NULL},
  {0x07, DTYPE_UNSIGNED32, 32, ATYPE_RO, acName1A00_07, 0x64010710, NULL},
  {0x08, DTYPE_UNSIGNED32, 32, ATYPE_RO, acName1A00_08, 0x64010810, NULL},
};
const _objd SDO1C00[] =
{
  {0x00, DTYPE_UNSIGNED8, 8, ATYPE_RO, acName1C00_00, 4, NULL},
  {0x01, DTYPE_UNSIGNED8, 8, ATYPE_RO, acName1C00_01, 1, NULL},
  {0x02, DTYPE_UNSIGNED8, 8, ATYPE_RO, acName1C00_02, 2, NULL},
  {0x03, DTYPE_UNSIGNED8, 8, ATYPE_RO, acName1C00_03, 3, NULL},
  {0x04, DTYPE_UNSIGNED8, 8, ATYPE_RO, acName1C00_04, 4, NULL},
};
const _objd SDO1C12[] =
{
  {0x00, DTYPE_UNSIGNED8, 8, ATYPE_RO, acName1C12_00, 1, NULL},
  {0x01, DTYPE_UNSIGNED16, 16, ATYPE_RO, acName1C12_01, 0x1600, NULL},
};
const _objd SDO1C13[] =
{
  {0x00, DTYPE_UNSIGNED8, 8, ATYPE_RO, acName1C13_00, 1, NULL},
  {0x01, DTYPE_UNSIGNED16, 16, ATYPE_RO, acName1C13_01, 0x1A00, NULL},
};
const _objd SDO1C32[] =
{
  {0x00, DTYPE_UNSIGNED8, 8, ATYPE_RO, acName1C32_00, 32, NULL},
  {0x01, DTYPE_UNSIGNED16, 16, ATYPE_RWpre, acName1C32_01, 2, &Obj.SyncManagerOutput.SyncMode},
  {0x02, DTYPE_UNSIGNED32, 32, ATYPE_RO, acName1C32_02, 0, &Obj.SyncManagerOutput.CycleTime},
  {0x04, DTYPE_UNSIGNED16, 16, ATYPE_RO, acName1C32_04, 0x0006, &Obj.SyncManagerOutput.SyncModesSupported},
  {0x05, DTYPE_UNSIGNED32, 32, ATYPE_RO, acName1C32_05, MIN_CYCLE_TIME_NS, &Obj.SyncManagerOutput.MinimumCycleTime},
  {0x06, DTYPE_UNSIGNED32, 32, ATYPE_RO, acName1C32_06, 0, &Obj.SyncManagerOutput.CalcAndCopyTime},
  {0x0C, DTYPE_UNSIGNED16, 16, ATYPE_RO, acName1C32_0C, 0, &Obj.SyncManagerOutput.CycleTimeTooSmall},
  {0x20, DTYPE_BOOLEAN, 1, ATYPE_RO, acName1C32_20, 0, &Obj.SyncManagerOutput.SyncError},
};
const _objd SDO1C33[] =
{
  {0x00, DTYPE_UNSIGNED8, 8, ATYPE_RO, acName1C33_00, 32, NULL},
  {0x01, DTYPE_UNSIGNED16, 16, ATYPE_RWpre, acName1C33_01, 2, &Obj.SyncManagerInput.SyncMode},
  {0x02, DTYPE_UNSIGNED32, 32, ATYPE_RO, acName1C33_02, 0, &Obj.SyncManagerInput.CycleTime},
  {0x04, DTYPE_UNSIGNED16, 16, ATYPE_RO, acName1C33_04, 0x0006, &Obj.SyncManagerInput.SyncModesSupported},
  {0x05, DTYPE_UNSIGNED32, 32, ATYPE_RO, acName1C33_05, MIN_CYCLE_TIME_NS, &Obj.SyncManagerInput.MinimumCycleTime},
  {0x06, DTYPE_UNSIGNED32, 32, ATYPE_RO, acName1C33_06, 0, &Obj.SyncManagerInput.CalcAndCopyTime},
  {0x0C, DTYPE_UNSIGNED16, 16, ATYPE_RO, acName1C33_0C, 0, &Obj.SyncManagerInput.CycleTimeTooSmall},
  {0x20, DTYPE_BOOLEAN, 1, ATYPE_RO, acName1C33_20, 0, &Obj.SyncManagerInput.SyncError},
};
const _objd SDO6401[] =
{
  {0x00, DTYPE_UNSIGNED8, 8, ATYPE_RO, acName6401_00, 8, NULL},
  {0x01, DTYPE_INTEGER16, 16, ATYPE_RO | ATYPE_TXPDO, acName6401_01, 0, &Obj.AnalogInput[0]},
  {0x02, DTYPE_INTEGER16, 16, ATYPE_RO | ATYPE_TXPDO, acName6401_02, 0, &Obj.AnalogInput[1]},
  {0x03, DTYPE_INTEGER16, 16, ATYPE_RO | ATYPE_TXPDO, acName6401_03, 0, &Obj.AnalogInput[2]},
  {0x04, DTYPE_INTEGER16, 16, ATYPE_RO | ATYPE_TXPDO, acName6401_04, 0, &Obj.AnalogInput[3]},
  {0x05, DTYPE_INTEGER16, 16, ATYPE_RO | ATYPE_TXPDO, acName6401_05, 0, &Obj.AnalogInput[4]},
  {0x06, DTYPE_INTEGER16, 16, ATYPE_RO | ATYPE_TXPDO, acName6401_06, 0, &Obj.AnalogInput[5]},
  {0x07, DTYPE_INTEGER16, 16, ATYPE_RO | ATYPE_TXPDO, acName6401_07, 0, &Obj.AnalogInput[6]},
  {0x08, DTYPE_INTEGER16, 16, ATYPE_RO | ATYPE_TXPDO, acName6401_08, 0, &Obj.AnalogInput[7]},
};
const _objd SDO6411[] =
{
  {0x00, DTYPE_UNSIGNED8, 8, ATYPE_RO, acName6411_00, 2, NULL},
  {0x01, DTYPE_INTEGER16, 16, ATYPE_RW | ATYPE_RXPDO, acName6411_01, 0, &Obj.AnalogOutput[0]},
  {0x02, DTYPE_INTEGER16, 16, ATYPE_RW | ATYPE_RXPDO, acName6411_02, 0, &Obj.AnalogOutput[1]},
};

const _objectlist SDOobjects[] =
{
  {0x1000, OTYPE_VAR, 0, 0, acName1000, SDO1000},
  {0x1008, OTYPE_VAR, 0, 0, acName1008, SDO1008},
  {0x1009, OTYPE_VAR, 0, 0, acName1009, SDO1009},
  {0x100A, OTYPE_VAR, 0, 0, acName100A, SDO100A},
  {0x1018, OTYPE_RECORD, 4, 0, acName1018, SDO1018},
  {0x10F1, OTYPE_RECORD, 2, 0, acName10F1, SDO10F1},
  {0x1600, OTYPE_RECORD, 2, 0, acName1600, SDO1600},
  {0x1A00, OTYPE_RECORD, 8, 0, acName1A00, SDO1A00},
  {0x1C00, OTYPE_ARRAY, 4, 0, acName1C00, SDO1C00},
  {0x1C12, OTYPE_ARRAY, 1, 0, acName1C12, SDO1C12},
  {0x1C13, OTYPE_ARRAY, 1, 0, acName1C13, SDO1C13},
  {0x1C32, OTYPE_RECORD, 32, 0, acName1C32, SDO1C32},
  {0x1C33, OTYPE_RECORD, 32, 0, acName1C33, SDO1C33},
  {0x6401, OTYPE_ARRAY, 8, 0, acName6401, SDO6401},
  {0x6411, OTYPE_ARRAY, 2, 0, acName6411, SDO6411},
  {0xffff, 0xff, 0xff, 0xff, NULL, NULL}
};
